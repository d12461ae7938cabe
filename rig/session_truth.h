// A simulated session's ground truth (core/truth.h SessionTruth) from the world it stored in
// <session>/rig/ (rig_config.h StoreRigWithSession): what the pipelines compare with and run their
// floors on. This is the one place processing's evaluation meets the simulator; the pipelines
// receive it through PipelineRequest::load_truth and include no sim/ header.
#pragma once

#include <filesystem>
#include <memory>

#include "core/truth.h"
#include "rig/rig_config.h"

namespace relume::rig {

// The truth of a session recorded from `rig` (which must have a world); keeps the rig alive.
std::shared_ptr<const SessionTruth> MakeSessionTruth(std::shared_ptr<const RigConfig> rig);

// The truth of the session in `session_dir`: null when the session stored no rig or its rig has
// no simulated world (a real capture, an imported session). Errors in the stored files are
// reported like LoadRigConfig's.
std::shared_ptr<const SessionTruth> LoadSessionTruth(const std::filesystem::path& session_dir);

}  // namespace relume::rig
