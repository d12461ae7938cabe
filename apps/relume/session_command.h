// `relume session verify | recover | info DIR`.
#pragma once

namespace CLI {
class App;
}

namespace relume::app {
void AddSessionCommand(CLI::App& app);
}  // namespace relume::app
