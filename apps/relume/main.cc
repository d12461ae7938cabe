// relume: the command-line entry point. It parses, wires layers together and reports errors;
// the work is done in the layers (see docs/architecture.md).
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <iostream>

#include "apps/relume/bench_command.h"
#include "apps/relume/calibrate_command.h"
#include "apps/relume/capture_command.h"
#include "apps/relume/devices_command.h"
#include "apps/relume/hdr_command.h"
#include "apps/relume/process_command.h"
#include "apps/relume/session_command.h"
#include "apps/relume/sim_command.h"
#include "apps/relume/sun_command.h"
#include "core/error.h"

int main(int argc, char** argv) {
  std::ios::sync_with_stdio(false);
  CLI::App app{"relume: capture rig control, radiometric calibration and relighting"};
  app.require_subcommand(1);
  relume::app::AddSunCommand(app);
  relume::app::AddSessionCommand(app);
  relume::app::AddCaptureCommand(app);
  relume::app::AddSimCommand(app);
  relume::app::AddCalibrateCommand(app);
  relume::app::AddHdrCommand(app);
  relume::app::AddBenchCommand(app);
  relume::app::AddProcessCommand(app);
  relume::app::AddDevicesCommand(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const relume::Error& e) {
    std::cout.flush();
    std::cerr << "relume: error: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
