#include "drivers/aravis/stream_timing.h"

#include <gtest/gtest.h>

#include <random>

#include "core/error.h"

namespace relume::drivers::aravis {
namespace {

TEST(FrameIdUnwrapperTest, CountsUpAcrossTheGigEWrapSkippingZero) {
  FrameIdUnwrapper unwrapper;  // 16 bits, zero invalid
  std::uint64_t previous = 0;
  std::uint16_t raw = 65530;
  for (int i = 0; i < 20; ++i) {
    const auto id = unwrapper.Next(raw);
    ASSERT_TRUE(id.has_value());
    if (i > 0) {
      EXPECT_EQ(id->sequence, previous + 1) << "raw " << raw;
      EXPECT_EQ(id->lost, 0u);
      EXPECT_EQ(id->wrapped, raw == 1);
    }
    previous = id->sequence;
    raw = raw == 65535 ? 1 : static_cast<std::uint16_t>(raw + 1);
  }
  EXPECT_EQ(unwrapper.wraps(), 1u);
}

TEST(FrameIdUnwrapperTest, LostFramesAcrossTheWrapAreCounted) {
  FrameIdUnwrapper unwrapper;
  ASSERT_TRUE(unwrapper.Next(65533));
  const auto id = unwrapper.Next(2);  // 65534, 65535 and 1 never arrived
  ASSERT_TRUE(id);
  EXPECT_EQ(id->sequence, 4u);
  EXPECT_EQ(id->lost, 3u);
  EXPECT_TRUE(id->wrapped);
  EXPECT_EQ(unwrapper.total_lost(), 3u);
}

TEST(FrameIdUnwrapperTest, DuplicatesAndZeroAreIgnored) {
  FrameIdUnwrapper unwrapper;
  ASSERT_TRUE(unwrapper.Next(10));
  EXPECT_FALSE(unwrapper.Next(10));
  EXPECT_FALSE(unwrapper.Next(0));
  const auto id = unwrapper.Next(11);
  ASSERT_TRUE(id);
  EXPECT_EQ(id->sequence, 1u);
}

TEST(FrameIdUnwrapperTest, CounterResetContinuesTheSequence) {
  FrameIdUnwrapper unwrapper;
  ASSERT_TRUE(unwrapper.Next(30000));
  ASSERT_TRUE(unwrapper.Next(30001));
  const auto id = unwrapper.Next(5);  // far behind: the camera restarted its counter
  ASSERT_TRUE(id);
  EXPECT_TRUE(id->restarted);
  EXPECT_EQ(id->sequence, 2u);
  EXPECT_EQ(id->lost, 0u);
}

TEST(FrameIdUnwrapperTest, SixtyFourBitCountersWrapToo) {
  FrameIdUnwrapperOptions options;
  options.counter_bits = 64;
  options.zero_is_invalid = false;
  FrameIdUnwrapper unwrapper(options);
  ASSERT_TRUE(unwrapper.Next(~std::uint64_t{0}));
  const auto id = unwrapper.Next(0);
  ASSERT_TRUE(id);
  EXPECT_EQ(id->sequence, 1u);
  EXPECT_TRUE(id->wrapped);
}

TEST(FrameIdUnwrapperTest, InvalidOptionsAreRejected) {
  FrameIdUnwrapperOptions options;
  options.counter_bits = 1;
  EXPECT_THROW(FrameIdUnwrapper{options}, InvalidArgumentError);
}

// A device clock 40 ppm fast with an arbitrary epoch; host times carry a fixed latency plus
// one-sided jitter (as leader-packet timestamps do).
TEST(DeviceClockMapperTest, RecoversDriftAndLowerEnvelopeOffset) {
  DeviceClockMapper mapper;
  std::mt19937 rng(7);
  std::exponential_distribution<double> jitter_ns(1.0 / 20000.0);  // mean 20 us
  const std::int64_t device_epoch = 123456789012;
  const UtcTime host_epoch = UtcTime(std::chrono::seconds(1'800'000'000));
  const double drift = 40e-6;
  const Nanoseconds latency = std::chrono::milliseconds(3);
  for (int i = 0; i < 200; ++i) {
    const double host_elapsed_ns = i * 20e6;  // 50 frames/s
    const auto device = Nanoseconds(device_epoch + static_cast<std::int64_t>(host_elapsed_ns * (1.0 + drift)));
    const UtcTime host = host_epoch + Nanoseconds(static_cast<std::int64_t>(host_elapsed_ns)) + latency +
                         Nanoseconds(static_cast<std::int64_t>(jitter_ns(rng)));
    mapper.AddSample(device, host);
  }
  const DeviceClockFitSummary& fit = mapper.summary();
  ASSERT_TRUE(fit.usable) << fit.reason;
  // Least squares: slope noise ~ jitter / (sqrt(n) * spread) = 20 us / (14 * 1.15 s) ~ 1.2 ppm.
  EXPECT_NEAR(fit.drift_ppm, -40.0, 5.0);  // host runs slower than the device: slope 1/(1+drift)
  EXPECT_GT(fit.residual_span_ns, 0.0);
  // A device instant maps to the least-delayed arrival: epoch + elapsed + latency (+ small).
  const double elapsed_ns = 1.5e9;
  const auto device = Nanoseconds(device_epoch + static_cast<std::int64_t>(elapsed_ns * (1.0 + drift)));
  const std::optional<UtcTime> mapped = mapper.Map(device);
  ASSERT_TRUE(mapped);
  const double error_ns = static_cast<double>(
      (*mapped - (host_epoch + Nanoseconds(static_cast<std::int64_t>(elapsed_ns)) + latency)).count());
  EXPECT_GE(error_ns, -20000.0);
  EXPECT_LT(error_ns, 20000.0);  // within 20 us of the least-delayed arrival
}

TEST(DeviceClockMapperTest, TooFewSamplesGiveNoMapping) {
  DeviceClockMapper mapper;
  mapper.AddSample(Nanoseconds(1000), UtcTime(Nanoseconds(5000)));
  EXPECT_FALSE(mapper.summary().usable);
  EXPECT_NE(mapper.summary().reason.find("fewer than"), std::string::npos);
  EXPECT_FALSE(mapper.Map(Nanoseconds(1000)));
}

TEST(DeviceClockMapperTest, FrozenDeviceClockIsReportedNotFitted) {
  DeviceClockMapper mapper;
  for (int i = 0; i < 20; ++i) mapper.AddSample(Nanoseconds(42), UtcTime(std::chrono::milliseconds(i * 10)));
  EXPECT_FALSE(mapper.summary().usable);
  EXPECT_NE(mapper.summary().reason.find("do not advance"), std::string::npos);
}

TEST(DeviceClockMapperTest, DeviceClockGoingBackwardsStartsAFreshFit) {
  DeviceClockMapper mapper;
  for (int i = 0; i < 20; ++i)
    mapper.AddSample(Nanoseconds(1'000'000'000 + i * 10'000'000), UtcTime(std::chrono::milliseconds(i * 10)));
  ASSERT_TRUE(mapper.summary().usable);
  mapper.AddSample(Nanoseconds(5), UtcTime(std::chrono::milliseconds(1000)));
  EXPECT_EQ(mapper.summary().samples, 1);
  EXPECT_FALSE(mapper.summary().usable);
}

}  // namespace
}  // namespace relume::drivers::aravis
