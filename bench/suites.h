// The random-scene suites (bench/suite.h), one function per suite. Each draws
// options.scenes scenes from its own seeded generator; see each file for the scene family,
// the method, the floor and the error metric.
#pragma once

#include "bench/suite.h"

namespace relume::bench {

// bench/sh_suite.cc: RGB-D SH lighting estimation + relighting (processing/sh_pipeline.h).
std::vector<SuiteResult> RunShIdealDepthSuite(const SuiteOptions& options);
std::vector<SuiteResult> RunShKinectNoiseSuite(const SuiteOptions& options);
std::vector<SuiteResult> RunShSmoothLightSuite(const SuiteOptions& options);
// The smooth-light scenes (the same draws) rendered with kSuiteBounces diffuse bounces between
// the objects and the wall (bench/primitive_bounces.h).
std::vector<SuiteResult> RunShSmoothLightBouncesSuite(const SuiteOptions& options);

// bench/radiosity_suite.cc: reflectance estimation with radiosity indirect light in random rooms.
std::vector<SuiteResult> RunRadiositySuite(const SuiteOptions& options);
// The same rooms with a grey chart, photographs in unknown units: the absolute scale from the chart.
std::vector<SuiteResult> RunRadiosityChartSuite(const SuiteOptions& options);

// HDR radiance from 5-frame brackets of random monotone responses: relume's response recovery
// + merge, and OpenCV's beside it, against the merge given the true response (bench/hdr_suite.cc).
std::vector<SuiteResult> RunHdrSuite(const SuiteOptions& options);

// IRM relighting on random outdoor scenes (bench/irm_suite.cc): lit, shadow and penumbra.
std::vector<SuiteResult> RunIrmSuite(const SuiteOptions& options);
// The same scenes rendered with kSuiteBounces diffuse bounces (bench/interreflection_truth.h).
inline constexpr int kSuiteBounces = 3;
std::vector<SuiteResult> RunIrmBouncesSuite(const SuiteOptions& options);

}  // namespace relume::bench
