// `relume batch SESSIONS... --out DIR [--local N | --slurm ...]`: many sessions through the
// pipelines with one set of options, one task per session, gathered into DIR/index.html
// (batch/, docs/batch.md); `relume batch-task PLAN INDEX ATTEMPT` runs one task (what the local
// workers and the Slurm job script call). Both only parse arguments and print.
#pragma once

namespace CLI {
class App;
}

namespace relume::app {

void AddBatchCommand(CLI::App& app);

}  // namespace relume::app
