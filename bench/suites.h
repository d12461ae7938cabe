// The random-scene suites (bench/suite.h), one function per suite. Each draws
// options.scenes scenes from its own seeded generator; see each file for the scene family,
// the method, the floor and the error metric.
#pragma once

#include "bench/suite.h"

namespace relume::bench {

// IRM relighting on random outdoor scenes (bench/irm_suite.cc): lit, shadow and penumbra.
std::vector<SuiteResult> RunIrmSuite(const SuiteOptions& options);

}  // namespace relume::bench
