#include "drivers/retry.h"

#include <algorithm>
#include <cmath>
#include <thread>

namespace relume::drivers {

bool RetryPolicy::IsValid(std::string* why) const {
  auto fail = [why](const char* reason) {
    if (why) *why = reason;
    return false;
  };
  if (max_attempts < 1 || max_attempts > 1000) return fail("max_attempts must be within 1..1000");
  if (initial_backoff.count() < 0 || max_backoff < initial_backoff) {
    return fail("backoffs must satisfy 0 <= initial_backoff <= max_backoff");
  }
  if (!(backoff_multiplier >= 1.0 && backoff_multiplier <= 100.0))
    return fail("backoff_multiplier must be in [1, 100]");
  return true;
}

Nanoseconds RetryPolicy::BackoffAfter(int attempt) const {
  const double scaled = static_cast<double>(initial_backoff.count()) * std::pow(backoff_multiplier, attempt - 1);
  return Nanoseconds(static_cast<Nanoseconds::rep>(std::min(scaled, static_cast<double>(max_backoff.count()))));
}

const char* ToString(DeviceEvent::Type type) {
  switch (type) {
    case DeviceEvent::Type::kRetry: return "retry";
    case DeviceEvent::Type::kGaveUp: return "gave_up";
    case DeviceEvent::Type::kReconnectAttempt: return "reconnect_attempt";
    case DeviceEvent::Type::kReconnected: return "reconnected";
  }
  return "unknown";
}

SleepFunction RealSleep() {
  return [](Nanoseconds duration) { std::this_thread::sleep_for(duration); };
}

namespace {
void Emit(const DeviceEventSink& sink, DeviceEvent event) {
  if (sink) sink(event);
}
}  // namespace

RetryingStillCamera::RetryingStillCamera(std::unique_ptr<StillCamera> inner, RetryPolicy policy, DeviceEventSink events,
                                         SleepFunction sleep)
    : inner_(std::move(inner)), policy_(policy), events_(std::move(events)), sleep_(std::move(sleep)) {
  RELUME_CHECK(inner_ != nullptr);
  ThrowIfInvalid(policy_, "retry policy");
}

template <typename Call>
auto RetryingStillCamera::WithRetries(Call&& call) -> decltype(call()) {
  for (int attempt = 1;; ++attempt) {
    try {
      return call();
    } catch (const DeviceError& e) {
      if (!e.retryable()) throw;
      DeviceEvent event{
          DeviceEvent::Type::kRetry, inner_->info().FullId(), e.kind(), attempt, Nanoseconds{0}, e.what()};
      if (attempt >= policy_.max_attempts) {
        event.type = DeviceEvent::Type::kGaveUp;
        Emit(events_, event);
        throw;
      }
      event.wait = policy_.BackoffAfter(attempt);
      Emit(events_, event);
      sleep_(event.wait);
    }
  }
}

void RetryingStillCamera::Apply(const ExposureSettings& settings) {
  WithRetries([&] { inner_->Apply(settings); });
}

StillFrame RetryingStillCamera::Capture() {
  return WithRetries([&] { return inner_->Capture(); });
}

ReconnectingStillCamera::ReconnectingStillCamera(std::unique_ptr<StillCamera> inner, Opener reopen, RetryPolicy policy,
                                                 DeviceEventSink events, SleepFunction sleep)
    : inner_(std::move(inner)),
      reopen_(std::move(reopen)),
      policy_(policy),
      events_(std::move(events)),
      sleep_(std::move(sleep)) {
  RELUME_CHECK(inner_ != nullptr && reopen_);
  ThrowIfInvalid(policy_, "reconnect policy");
  info_ = inner_->info();
}

void ReconnectingStillCamera::Reconnect(const DeviceError& cause) {
  inner_.reset();
  std::string last_error = cause.what();
  for (int attempt = 1; attempt <= policy_.max_attempts; ++attempt) {
    const Nanoseconds wait = policy_.BackoffAfter(attempt);
    Emit(events_, {DeviceEvent::Type::kReconnectAttempt, info_.FullId(), cause.kind(), attempt, wait, last_error});
    sleep_(wait);
    try {
      std::unique_ptr<StillCamera> camera = reopen_();
      if (!camera) continue;
      camera->Apply(applied_);
      inner_ = std::move(camera);
      Emit(events_, {DeviceEvent::Type::kReconnected, info_.FullId(), cause.kind(), attempt, Nanoseconds{0}, ""});
      return;
    } catch (const DeviceError& e) {
      last_error = e.what();
    }
  }
  Emit(events_,
       {DeviceEvent::Type::kGaveUp, info_.FullId(), cause.kind(), policy_.max_attempts, Nanoseconds{0}, last_error});
  throw DeviceError(DeviceErrorKind::kDisconnected, info_.FullId(),
                    "reconnect failed after " + std::to_string(policy_.max_attempts) +
                        " attempts (last error: " + last_error + "); check the cable and power");
}

template <typename Call>
auto ReconnectingStillCamera::WithReconnect(Call&& call) -> decltype(call()) {
  if (!inner_) Reconnect(DeviceError(DeviceErrorKind::kDisconnected, info_.FullId(), "not connected"));
  try {
    return call();
  } catch (const DeviceError& e) {
    if (e.kind() != DeviceErrorKind::kDisconnected) throw;
    Reconnect(e);
    return call();
  }
}

ExposureCapabilities ReconnectingStillCamera::capabilities() const {
  if (!inner_) throw DeviceError(DeviceErrorKind::kDisconnected, info_.FullId(), "not connected");
  return inner_->capabilities();
}

namespace {
void Merge(ExposureSettings& into, const ExposureSettings& from) {
  if (from.exposure_time_s) into.exposure_time_s = from.exposure_time_s;
  if (from.ev_compensation) into.ev_compensation = from.ev_compensation;
  if (from.aperture_f) into.aperture_f = from.aperture_f;
  if (from.iso) into.iso = from.iso;
  if (from.gain_db) into.gain_db = from.gain_db;
}
}  // namespace

void ReconnectingStillCamera::Apply(const ExposureSettings& settings) {
  WithReconnect([&] { inner_->Apply(settings); });
  Merge(applied_, settings);
}

StillFrame ReconnectingStillCamera::Capture() {
  return WithReconnect([&] { return inner_->Capture(); });
}

}  // namespace relume::drivers
