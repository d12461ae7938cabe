// `relume process SESSION --pipeline NAME --out DIR`: reprocesses a recorded session through
// one pipeline (pipeline/), reusing every stage whose inputs and settings did not
// change since the last run into the same folder. `--explain` prints the plan without running
// expensive stages; `--list` names the pipelines of this build.
#pragma once

namespace CLI {
class App;
}

namespace relume::app {

void AddProcessCommand(CLI::App& app);

}  // namespace relume::app
