#include "core/sun/delta_t.h"

#include <gtest/gtest.h>

#include <cmath>

namespace relume {
namespace {

TEST(DeltaTTest, KnownValues) {
  EXPECT_NEAR(DeltaTModelSeconds(2000.0), 63.86, 1e-9);
  EXPECT_NEAR(DeltaTModelSeconds(1975.0), 45.45, 1e-9);
  EXPECT_NEAR(DeltaTModelSeconds(1950.0), 29.07, 1e-9);
  EXPECT_NEAR(DeltaTModelSeconds(1900.0), -2.79, 1e-9);
  // Observed values (IERS) stay within a few seconds of the model: 1990 56.9 s, 2010 66.1 s.
  EXPECT_NEAR(DeltaTModelSeconds(1990.0), 56.9, 1.0);
  EXPECT_NEAR(DeltaTModelSeconds(2010.0), 66.1, 1.5);
}

TEST(DeltaTTest, BranchesJoinWithoutJumps) {
  for (double boundary : {1860.0, 1900.0, 1920.0, 1941.0, 1961.0, 1986.0, 2005.0, 2050.0, 2150.0}) {
    const double before = DeltaTModelSeconds(boundary - 1e-9);
    const double after = DeltaTModelSeconds(boundary);
    EXPECT_NEAR(before, after, 1.0) << "at " << boundary;
  }
}

TEST(DeltaTTest, FiniteEverywhereInTheSpaRange) {
  for (double year = -2000.0; year <= 6000.0; year += 7.3) EXPECT_TRUE(std::isfinite(DeltaTModelSeconds(year)));
}

}  // namespace
}  // namespace relume
