#include "core/site.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"

namespace relume {
namespace {

TEST(SiteTest, FromDegreesKeepsValues) {
  const Site site = Site::FromDegrees(39.742476, -105.1786, 1830.14);
  EXPECT_NEAR(site.latitude_deg(), 39.742476, 1e-12);
  EXPECT_NEAR(site.longitude_deg(), -105.1786, 1e-12);
  EXPECT_EQ(site.height_m, 1830.14);
  EXPECT_NO_THROW(Site::FromDegrees(90, 180, 0));
  EXPECT_NO_THROW(Site::FromDegrees(-90, -180, 0));
}

TEST(SiteTest, RejectsOutOfRangeAndNan) {
  EXPECT_THROW(Site::FromDegrees(90.001, 0), InvalidArgumentError);
  EXPECT_THROW(Site::FromDegrees(0, 180.5), InvalidArgumentError);
  EXPECT_THROW(Site::FromDegrees(NAN, 0), InvalidArgumentError);
  EXPECT_THROW(Site::FromDegrees(0, 0, INFINITY), InvalidArgumentError);
  EXPECT_THROW(Site::FromDegrees(0, 0, 20000), InvalidArgumentError);
  std::string why;
  EXPECT_FALSE((Site{DegToRad(-95.0), 0, 0}).IsValid(&why));
  EXPECT_NE(why.find("latitude"), std::string::npos);
}

}  // namespace
}  // namespace relume
