// The simulator's name for the ground-truth contract (core/truth.h): the simulated world
// (sim/world/) is a TruthSource, and simulated devices (sim/devices/) render from one.
#pragma once

#include "core/truth.h"

namespace relume::sim {

using GroundTruth = relume::GroundTruth;
using TruthSource = relume::TruthSource;

}  // namespace relume::sim
