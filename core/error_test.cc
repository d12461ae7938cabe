#include "core/error.h"

#include <gtest/gtest.h>

namespace relume {
namespace {

struct FakeOptions {
  int value = 0;
  bool IsValid(std::string* why) const {
    if (value >= 0) return true;
    *why = "value must be >= 0";
    return false;
  }
};

TEST(ErrorTest, MessagesNameWhereAndWhat) {
  const ConfigError config("rigs/site.yaml", 12, "schedule.every_minutes", "expected a positive number");
  EXPECT_STREQ(config.what(), "rigs/site.yaml:12: schedule.every_minutes: expected a positive number");
  EXPECT_EQ(config.line(), 12);
  const IoError io("/data/session", "disk full");
  EXPECT_STREQ(io.what(), "/data/session: disk full");
  const Error& base = io;
  EXPECT_EQ(std::string(base.what()), "/data/session: disk full");
}

TEST(ErrorTest, ThrowIfInvalid) {
  EXPECT_NO_THROW(ThrowIfInvalid(FakeOptions{1}, "fake"));
  try {
    ThrowIfInvalid(FakeOptions{-1}, "fake options");
    FAIL();
  } catch (const InvalidArgumentError& e) {
    EXPECT_STREQ(e.what(), "fake options: value must be >= 0");
  }
}

TEST(ErrorDeathTest, CheckAbortsWithLocation) {
  EXPECT_DEATH(RELUME_CHECK_MSG(1 + 1 == 3, "arithmetic"), "check `1 \\+ 1 == 3` failed: arithmetic");
}

}  // namespace
}  // namespace relume
