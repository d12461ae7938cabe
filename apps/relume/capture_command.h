// `relume capture --rig FILE --out DIR [--duration MIN] [--speedup X]`: records a session.
#pragma once

#include <string>

#include "drivers/backend.h"
#include "rig/rig_config.h"

namespace CLI {
class App;
}

namespace relume::app {

struct CaptureRequest {
  std::string rig_path;
  std::string out_dir;
  double duration_minutes = 0.0;  // 0 = the rig's
  double speedup = 0.0;           // 0 = the rig's
  bool progress = true;
};

// The enumerated device a rig entry names (every key given must match). Throws
// DeviceError(kNotFound) naming the entry, what its backend sees and what to check.
drivers::DeviceInfo ResolveRigDevice(const drivers::DeviceRegistry& registry, const rig::RegistryDeviceSpec& spec);

// Returns the process exit code: 0 done, 3 storage failed (acknowledged frames are safe).
int RunCapture(const CaptureRequest& request);
void AddCaptureCommand(CLI::App& app);

}  // namespace relume::app
