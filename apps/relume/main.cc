// relume: the command-line entry point. It parses, wires layers together and reports errors;
// the work is done in the layers (see docs/architecture.md).
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <opencv2/core/utility.hpp>
#include <iostream>
#include <new>
#include <string>

#include "apps/relume/batch_command.h"
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
#include "core/parallel.h"

namespace {

int ReportError(const std::string& what) {
  std::cout.flush();
  std::cerr << "relume: error: " << what << "\n";
  return 2;
}

}  // namespace

// Every exception ends here as "relume: error: ..." with exit code 2: no input reaches
// std::terminate. relume::Error is the expected kind (it names the file, key or flag); the
// others come from libraries (yaml-cpp, OpenCV, the standard library) on input relume did not
// check, and are bugs to fix at their source, but still not crashes.
int main(int argc, char** argv) {
  std::ios::sync_with_stdio(false);
  // OpenCV's own loops get the same CPUs as relume's (core/parallel.h: RELUME_THREADS, a Slurm
  // task's share, the affinity mask), so that batch workers do not oversubscribe the machine.
  cv::setNumThreads(relume::DefaultThreads());
  CLI::App app{"relume: capture rig control, radiometric calibration and relighting"};
  // Parse errors read like every other error (CLI11's own text after the prefix).
  app.failure_message([](const CLI::App* failed, const CLI::Error& e) {
    return "relume: error: " + std::string(e.what()) + "\nRun with " + failed->get_help_ptr()->get_name() +
           " for more information.\n";
  });
  try {
    app.require_subcommand(1);
    relume::app::AddSunCommand(app);
    relume::app::AddSessionCommand(app);
    relume::app::AddCaptureCommand(app);
    relume::app::AddSimCommand(app);
    relume::app::AddCalibrateCommand(app);
    relume::app::AddHdrCommand(app);
    relume::app::AddBenchCommand(app);
    relume::app::AddProcessCommand(app);
    relume::app::AddBatchCommand(app);
    relume::app::AddDevicesCommand(app);
    app.parse(argc, argv);
  } catch (const CLI::RuntimeError& e) {
    return e.get_exit_code();  // a command's own exit code (capture: 3 when storage failed)
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; every real parse error exits 2 like any other user error
    // (CLI11's own codes 104-109 would tell scripts nothing).
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  } catch (const relume::Error& e) {
    return ReportError(e.what());
  } catch (const std::bad_alloc&) {
    return ReportError("out of memory (an input asks for more than this machine has)");
  } catch (const std::exception& e) {
    return ReportError(e.what());
  } catch (...) {
    return ReportError("an unknown exception (a bug, please report it)");
  }
  return 0;
}
