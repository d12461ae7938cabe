#include "drivers/aravis/stream_timing.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"

namespace relume::drivers::aravis {

bool FrameIdUnwrapperOptions::IsValid(std::string* why) const {
  if (counter_bits < 2 || counter_bits > 64) {
    if (why) *why = "counter_bits must be within 2..64";
    return false;
  }
  return true;
}

FrameIdUnwrapper::FrameIdUnwrapper(FrameIdUnwrapperOptions options) : options_(options) {
  ThrowIfInvalid(options_, "FrameIdUnwrapperOptions");
  // cycle_ == 0 stands for 2^64 (unsigned arithmetic below wraps accordingly).
  const std::uint64_t ids = options_.counter_bits == 64 ? 0 : (std::uint64_t{1} << options_.counter_bits);
  cycle_ = ids - (options_.zero_is_invalid ? 1 : 0);
}

std::uint64_t FrameIdUnwrapper::Position(std::uint64_t raw_id) const {
  return options_.zero_is_invalid ? raw_id - 1 : raw_id;
}

std::optional<UnwrappedFrameId> FrameIdUnwrapper::Next(std::uint64_t raw_id) {
  if (options_.counter_bits < 64) raw_id &= (std::uint64_t{1} << options_.counter_bits) - 1;
  if (options_.zero_is_invalid && raw_id == 0) return std::nullopt;
  const std::uint64_t position = Position(raw_id);
  UnwrappedFrameId out;
  if (!last_position_) {
    last_position_ = position;
    out.sequence = sequence_;
    return out;
  }
  const std::uint64_t last = *last_position_;
  if (position == last) return std::nullopt;
  const std::uint64_t delta = position > last ? position - last : (cycle_ - last) + position;
  const std::uint64_t half = cycle_ == 0 ? (std::uint64_t{1} << 63) : cycle_ / 2;
  if (delta > half) {
    // Far behind: the device restarted its counter (reopen, acquisition restart on some
    // cameras). Continue the sequence without counting losses.
    out.restarted = true;
    sequence_ += 1;
  } else {
    out.wrapped = position < last;
    out.lost = delta - 1;
    sequence_ += delta;
    total_lost_ += out.lost;
    if (out.wrapped) ++wraps_;
  }
  last_position_ = position;
  out.sequence = sequence_;
  return out;
}

bool DeviceClockMapperOptions::IsValid(std::string* why) const {
  if (min_samples < 2 || window < min_samples) {
    if (why) *why = "need 2 <= min_samples <= window";
    return false;
  }
  return true;
}

DeviceClockMapper::DeviceClockMapper(DeviceClockMapperOptions options) : options_(options) {
  ThrowIfInvalid(options_, "DeviceClockMapperOptions");
  Reset();
}

void DeviceClockMapper::Reset() {
  samples_.clear();
  summary_ = {};
  summary_.reason = "no samples yet";
}

void DeviceClockMapper::AddSample(Nanoseconds device_time, UtcTime host_time) {
  const std::int64_t device_ns = device_time.count();
  if (!samples_.empty() && device_ns < samples_.back().first) {
    // The device clock went backwards (reset or reopen): the old fit no longer applies.
    samples_.clear();
  }
  samples_.emplace_back(device_ns, host_time.time_since_epoch().count());
  while (static_cast<int>(samples_.size()) > options_.window) samples_.pop_front();
  Refit();
}

void DeviceClockMapper::Refit() {
  summary_ = {};
  summary_.samples = static_cast<int>(samples_.size());
  if (summary_.samples < options_.min_samples) {
    summary_.reason = "fewer than " + std::to_string(options_.min_samples) + " samples";
    return;
  }
  // Work relative to the first sample so that doubles keep sub-nanosecond precision.
  device_ref_ = samples_.front().first;
  host_ref_ = samples_.front().second;
  const double n = static_cast<double>(samples_.size());
  double mean_x = 0.0, mean_y = 0.0;
  for (const auto& [d, h] : samples_) {
    mean_x += static_cast<double>(d - device_ref_);
    mean_y += static_cast<double>(h - host_ref_);
  }
  mean_x /= n;
  mean_y /= n;
  double sxx = 0.0, sxy = 0.0;
  for (const auto& [d, h] : samples_) {
    const double x = static_cast<double>(d - device_ref_) - mean_x;
    const double y = static_cast<double>(h - host_ref_) - mean_y;
    sxx += x * x;
    sxy += x * y;
  }
  summary_.condition = std::sqrt(sxx / n) * 1e-9;
  if (sxx <= 1e6 * n) {  // device times spread by less than ~1 us: the clock is not advancing
    summary_.reason = "device timestamps do not advance (the camera may not provide them)";
    return;
  }
  slope_ = sxy / sxx;
  if (!(slope_ > 0.5 && slope_ < 2.0)) {
    summary_.reason = "device and host clocks disagree by more than a factor 2 (wrong timestamp unit?)";
    return;
  }
  const double line_at_ref = mean_y - slope_ * mean_x;
  double sum_sq = 0.0;
  double min_residual = std::numeric_limits<double>::infinity();
  double max_residual = -std::numeric_limits<double>::infinity();
  for (const auto& [d, h] : samples_) {
    const double r = static_cast<double>(h - host_ref_) - (line_at_ref + slope_ * static_cast<double>(d - device_ref_));
    sum_sq += r * r;
    min_residual = std::min(min_residual, r);
    max_residual = std::max(max_residual, r);
  }
  intercept_ns_ = line_at_ref + min_residual;
  summary_.usable = true;
  summary_.reason = "ok";
  summary_.drift_ppm = (slope_ - 1.0) * 1e6;
  summary_.offset_ns = static_cast<double>(host_ref_ - device_ref_) + intercept_ns_;
  summary_.residual_rms_ns = std::sqrt(sum_sq / n);
  summary_.residual_span_ns = max_residual - min_residual;
}

std::optional<UtcTime> DeviceClockMapper::Map(Nanoseconds device_time) const {
  if (!summary_.usable) return std::nullopt;
  const double host_rel = intercept_ns_ + slope_ * static_cast<double>(device_time.count() - device_ref_);
  return UtcTime(Nanoseconds(host_ref_ + static_cast<std::int64_t>(std::llround(host_rel))));
}

}  // namespace relume::drivers::aravis
