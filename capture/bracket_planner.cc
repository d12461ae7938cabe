#include "capture/bracket_planner.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/color.h"
#include "core/error.h"

namespace relume::capture {

namespace {

// One exposure the camera can take, as a relative exposure plus how to ask for it.
struct Choice {
  double relative = 1.0;
  PlannedExposure planned;
};

// The camera's discrete choices (shutter list or EV steps) relative to the metering frame.
std::vector<Choice> DiscreteChoices(const drivers::ExposureCapabilities& caps, double metering_time_s,
                                    double metering_ev) {
  std::vector<Choice> choices;
  if (caps.control == drivers::ExposureControl::kShutterList) {
    for (double t : caps.shutter_speeds_s) {
      Choice c;
      c.relative = t / metering_time_s;
      c.planned.relative_exposure = c.relative;
      c.planned.exposure_time_s = t;
      choices.push_back(c);
    }
  } else if (caps.control == drivers::ExposureControl::kEvOnly) {
    for (double ev : caps.ev_steps) {
      Choice c;
      c.relative = std::exp2(ev - metering_ev);
      c.planned.relative_exposure = c.relative;
      c.planned.ev_compensation = ev;
      choices.push_back(c);
    }
  }
  std::sort(choices.begin(), choices.end(), [](const Choice& a, const Choice& b) { return a.relative < b.relative; });
  return choices;
}

// Index of the choice nearest to `target` in stops; `mode` < 0 prefers <= target, > 0 prefers >= target.
std::size_t Snap(const std::vector<Choice>& choices, double target, int mode) {
  std::size_t best = 0;
  double best_distance = INFINITY;
  for (std::size_t i = 0; i < choices.size(); ++i) {
    const double stops = std::log2(choices[i].relative / target);
    double distance = std::abs(stops);
    if ((mode < 0 && stops > 1e-9) || (mode > 0 && stops < -1e-9)) distance += 1000.0;  // wrong side
    if (distance < best_distance) {
      best_distance = distance;
      best = i;
    }
  }
  return best;
}

}  // namespace

bool BracketPlannerOptions::IsValid(std::string* why) const {
  auto fail = [why](const char* reason) {
    if (why) *why = reason;
    return false;
  };
  if (!(saturation_fraction > 0.0 && saturation_fraction <= 1.0)) return fail("saturation_fraction must be in (0, 1]");
  if (!(min_signal_fraction > 0.0 && min_signal_fraction < saturation_fraction)) {
    return fail("min_signal_fraction must be in (0, saturation_fraction)");
  }
  if (!(overlap_stops >= 0.0 && overlap_stops < std::log2(saturation_fraction / min_signal_fraction))) {
    return fail("overlap_stops must be >= 0 and less than one frame's usable range");
  }
  if (!(dark_percentile >= 0.0 && dark_percentile < bright_percentile && bright_percentile <= 1.0)) {
    return fail("need 0 <= dark_percentile < bright_percentile <= 1");
  }
  if (!(clipped_share >= 0.0 && clipped_share < 1.0)) return fail("clipped_share must be in [0, 1)");
  if (!(clipped_extension_stops >= 0.0 && clipped_extension_stops <= 20.0)) {
    return fail("clipped_extension_stops must be in [0, 20]");
  }
  if (max_exposures < 1 || max_exposures > 64) return fail("max_exposures must be within 1..64");
  if (!(unequal_steps >= 0.0 && unequal_steps <= 0.5)) return fail("unequal_steps must be in [0, 0.5]");
  return true;
}

drivers::ExposureSettings PlannedExposure::Settings() const {
  drivers::ExposureSettings settings;
  settings.exposure_time_s = exposure_time_s;
  settings.ev_compensation = ev_compensation;
  return settings;
}

MeteringStats MeasureMeteringFrame(const CameraImage& frame, double relative_exposure,
                                   const BracketPlannerOptions& options,
                                   const std::function<double(double)>& inverse_response, const cv::Mat& mask) {
  ThrowIfInvalid(options, "bracket planner options");
  std::string why;
  if (!frame.IsValid(&why)) throw InvalidArgumentError("metering frame: " + why);
  if (!(relative_exposure > 0.0 && std::isfinite(relative_exposure))) {
    throw InvalidArgumentError("metering frame: relative exposure must be positive");
  }
  const int channels = frame.pixels.channels();
  const double black = frame.black_level;
  const double range = frame.white_level - frame.black_level;
  // Linear signal per code value, once.
  const int codes = frame.pixels.depth() == CV_8U ? 256 : 65536;
  std::vector<double> linear(static_cast<std::size_t>(codes));
  for (int v = 0; v < codes; ++v) {
    const double normalised = std::clamp((v - black) / range, 0.0, 1.0);
    double s = normalised;
    if (inverse_response) {
      s = inverse_response(normalised);
    } else if (frame.encoding == SampleEncoding::kCameraResponse) {
      s = SrgbDecode(normalised);
    }
    linear[static_cast<std::size_t>(v)] = s;
  }
  std::vector<double> signals;
  signals.reserve(frame.pixels.total());
  std::size_t clipped = 0, black_pixels = 0;
  for (int y = 0; y < frame.pixels.rows; ++y) {
    const std::uint8_t* mask_row = mask.empty() ? nullptr : mask.ptr<std::uint8_t>(y);
    for (int x = 0; x < frame.pixels.cols; ++x) {
      if (mask_row && mask_row[x] == 0) continue;
      double max_signal = 0.0;
      bool any_clipped = false;
      for (int c = 0; c < channels; ++c) {
        const int code = frame.pixels.depth() == CV_8U ? frame.pixels.ptr<std::uint8_t>(y)[x * channels + c]
                                                       : frame.pixels.ptr<std::uint16_t>(y)[x * channels + c];
        max_signal = std::max(max_signal, linear[static_cast<std::size_t>(code)]);
        any_clipped = any_clipped || code >= frame.white_level;
      }
      clipped += any_clipped ? 1 : 0;
      black_pixels += max_signal <= 0.0 ? 1 : 0;
      signals.push_back(max_signal);
    }
  }
  if (signals.empty()) throw InvalidArgumentError("metering frame: the mask selects no pixels");
  auto percentile = [&](double p) {
    const std::size_t k =
        std::min(signals.size() - 1, static_cast<std::size_t>(p * static_cast<double>(signals.size())));
    std::nth_element(signals.begin(), signals.begin() + static_cast<std::ptrdiff_t>(k), signals.end());
    return signals[k];
  };
  MeteringStats stats;
  stats.relative_exposure = relative_exposure;
  stats.dark_signal = percentile(options.dark_percentile);
  stats.bright_signal = percentile(options.bright_percentile);
  stats.clipped_share = static_cast<double>(clipped) / static_cast<double>(signals.size());
  stats.black_share = static_cast<double>(black_pixels) / static_cast<double>(signals.size());
  return stats;
}

namespace {
// Gaps (in stops) between n exposures over `span` stops that alternate 1 + d and 1 - d times
// their mean, with the largest d <= options.unequal_steps that keeps every gap within
// `step_stops` (so coverage holds). When that d is below half of unequal_steps, one exposure
// more is tried (while `may_add`, within max_exposures). Two exposures have one ratio and are
// left as they are. d = 0: equal gaps.
struct UnequalSteps {
  int exposures = 1;
  double d = 0.0;
  std::vector<double> gaps;
};
UnequalSteps ChooseUnequalSteps(double span, double step_stops, int n, const BracketPlannerOptions& options,
                                bool may_add) {
  auto largest_d = [&](int count) {
    const int g = count - 1;
    if (g < 2 || options.unequal_steps <= 0.0) return 0.0;  // one ratio (or none): nothing to vary
    // max gap = span (1 + d) / (g + d (g mod 2)) <= step_stops
    const double room = step_stops * g - span;
    const double denominator = span - step_stops * (g % 2);
    if (room <= 0.0) return 0.0;
    const double d = denominator > 0.0 ? room / denominator : options.unequal_steps;
    return std::clamp(d, 0.0, options.unequal_steps);
  };
  UnequalSteps out;
  out.exposures = n;
  out.d = largest_d(n);
  if (out.d < 0.5 * options.unequal_steps && n >= 3 && may_add && n + 1 <= options.max_exposures &&
      options.unequal_steps > 0.0) {
    const double more = largest_d(n + 1);
    if (more >= 0.5 * options.unequal_steps) {
      out.exposures = n + 1;
      out.d = more;
    }
  }
  const int g = out.exposures - 1;
  double total = 0.0;
  for (int i = 0; i < g; ++i) {
    out.gaps.push_back(1.0 + (i % 2 == 0 ? out.d : -out.d));
    total += out.gaps.back();
  }
  for (double& gap : out.gaps) gap *= span / total;
  return out;
}
}  // namespace

BracketPlan PlanBracket(const MeteringStats& metering, const drivers::ExposureCapabilities& caps,
                        double metering_exposure_time_s, double metering_ev, const BracketPlannerOptions& options) {
  ThrowIfInvalid(options, "bracket planner options");
  const bool ev_only = caps.control == drivers::ExposureControl::kEvOnly;
  if (!ev_only && !(metering_exposure_time_s > 0.0 && std::isfinite(metering_exposure_time_s))) {
    throw InvalidArgumentError("bracket planner: the metering exposure time must be positive");
  }
  BracketPlan plan;
  std::vector<std::string> notes;
  // Radiance bounds, in linear signal per unit relative exposure of the metering frame.
  double bright = metering.bright_signal / metering.relative_exposure;
  if (metering.clipped_share > options.clipped_share) {
    bright = std::exp2(options.clipped_extension_stops) / metering.relative_exposure;
    plan.range_known = false;
    notes.push_back("the metering frame clips, so the bright end is unknown: planned " +
                    std::to_string(options.clipped_extension_stops) + " stops darker and will extend adaptively");
  }
  constexpr double kNoSignal = 1e-9;  // below any real quantisation step: no signal at all
  double dark = metering.dark_signal / metering.relative_exposure;
  if (metering.dark_signal <= kNoSignal) {
    dark = kNoSignal / metering.relative_exposure;
    notes.push_back("the darkest regions show no signal in the metering frame; the longest exposure is a guess");
  }
  bright = std::max(bright, dark);
  plan.scene_range_stops = std::log2(bright / dark);

  const double short_relative = options.saturation_fraction / bright;  // brightest just below saturation
  const double long_relative = options.min_signal_fraction / dark;     // darkest just above the noise floor
  const double frame_range_stops = std::log2(options.saturation_fraction / options.min_signal_fraction);
  const double step_stops = frame_range_stops - options.overlap_stops;

  std::vector<double> targets;
  if (long_relative <= short_relative) {
    targets.push_back(short_relative);
    // First in the notes. (Built as a new vector: GCC 12 at -O3 warns falsely, -Warray-bounds,
    // on inserting a string literal at the front.)
    std::vector<std::string> first{"the scene's range fits one exposure"};
    first.insert(first.end(), std::make_move_iterator(notes.begin()), std::make_move_iterator(notes.end()));
    notes = std::move(first);
  } else {
    const double span = std::log2(long_relative / short_relative);
    int n = static_cast<int>(std::ceil(span / step_stops - 1e-9)) + 1;
    if (n > options.max_exposures) {
      n = options.max_exposures;
      plan.covers_range = false;
      notes.push_back("the range needs more than max_exposures; the darkest regions will be noisier");
    }
    const UnequalSteps unequal = ChooseUnequalSteps(span, step_stops, n, options, plan.covers_range);
    n = unequal.exposures;
    double stops = 0.0;
    for (int i = 0; i < n; ++i) {
      targets.push_back(short_relative * std::exp2(stops));
      if (i + 1 < n) stops += unequal.gaps[static_cast<std::size_t>(i)];
    }
    if (unequal.d > 0.0) {
      char text[160];
      std::snprintf(text, sizeof(text),
                    "steps alternate %.2f and %.2f stops (unequal exposure ratios let the response be recovered "
                    "from the bracket)",
                    unequal.gaps.front(), unequal.gaps.size() > 1 ? unequal.gaps[1] : unequal.gaps.front());
      notes.push_back(text);
    }
  }

  if (caps.control == drivers::ExposureControl::kContinuous) {
    for (double target : targets) {
      const double t = target * metering_exposure_time_s;
      const double clamped = std::clamp(t, caps.min_exposure_time_s, caps.max_exposure_time_s);
      if (std::abs(std::log2(clamped / t)) > 0.01) plan.covers_range = false;
      PlannedExposure e;
      e.exposure_time_s = clamped;
      e.relative_exposure = clamped / metering_exposure_time_s;
      if (plan.exposures.empty() || e.relative_exposure > plan.exposures.back().relative_exposure * 1.0001) {
        plan.exposures.push_back(e);
      }
    }
  } else {
    const std::vector<Choice> choices = DiscreteChoices(caps, metering_exposure_time_s, metering_ev);
    if (choices.empty()) throw InvalidArgumentError("bracket planner: the camera offers no exposure values");
    std::vector<std::size_t> picked;
    for (std::size_t i = 0; i < targets.size(); ++i) {
      const int mode = i == 0 ? -1 : (i + 1 == targets.size() && targets.size() > 1 ? +1 : 0);
      picked.push_back(Snap(choices, targets[i], mode));
    }
    std::sort(picked.begin(), picked.end());
    picked.erase(std::unique(picked.begin(), picked.end()), picked.end());
    // Fill gaps that snapping widened beyond one step.
    for (std::size_t i = 0; i + 1 < picked.size(); ++i) {
      const double gap = std::log2(choices[picked[i + 1]].relative / choices[picked[i]].relative);
      if (gap > step_stops + 1e-6 && picked[i + 1] > picked[i] + 1) {
        const double middle = std::sqrt(choices[picked[i + 1]].relative * choices[picked[i]].relative);
        std::size_t inside = Snap(choices, middle, 0);
        inside = std::clamp(inside, picked[i] + 1, picked[i + 1] - 1);
        picked.insert(picked.begin() + static_cast<std::ptrdiff_t>(i + 1), inside);
        --i;  // recheck the first half
      }
    }
    for (std::size_t index : picked) plan.exposures.push_back(choices[index].planned);
    const double first_error = std::log2(plan.exposures.front().relative_exposure / short_relative);
    const double last_error =
        std::log2(plan.exposures.back().relative_exposure / (targets.size() > 1 ? targets.back() : short_relative));
    if (first_error > 0.5 || (targets.size() > 1 && last_error < -0.5)) {
      plan.covers_range = false;
      notes.push_back("the camera's exposure limits cannot cover the whole range");
    }
  }
  for (std::size_t i = 0; i < notes.size(); ++i) plan.reason += (i ? "; " : "") + notes[i];
  if (plan.reason.empty()) {
    plan.reason = std::to_string(plan.exposures.size()) + " exposures cover " +
                  std::to_string(plan.scene_range_stops).substr(0, 4) + " stops";
  }
  return plan;
}

BracketPlan PlanUnmeteredBracket(const drivers::ExposureCapabilities& caps, double metering_exposure_time_s,
                                 double metering_ev, const BracketPlannerOptions& options, double stops_each_side) {
  if (!(stops_each_side >= 0.0 && stops_each_side <= 20.0)) {
    throw InvalidArgumentError("bracket planner: stops_each_side must be in [0, 20]");
  }
  // A scene whose bright end reaches saturation `stops_each_side` stops below the metering
  // exposure and whose dark end reaches the noise floor as far above it.
  MeteringStats assumed;
  assumed.bright_signal = options.saturation_fraction * std::exp2(stops_each_side);
  assumed.dark_signal = options.min_signal_fraction * std::exp2(-stops_each_side);
  BracketPlan plan = PlanBracket(assumed, caps, metering_exposure_time_s, metering_ev, options);
  plan.range_known = false;
  plan.reason =
      "not metered (the metering frame has no pixels relume can decode): " + std::to_string(plan.exposures.size()) +
      " exposures over +-" + std::to_string(stops_each_side).substr(0, 3) + " stops around the metering exposure";
  return plan;
}

std::optional<PlannedExposure> ExtendDarker(const MeteringStats& darkest_frame, const PlannedExposure& darkest,
                                            const drivers::ExposureCapabilities& caps, double metering_exposure_time_s,
                                            double metering_ev, const BracketPlannerOptions& options) {
  ThrowIfInvalid(options, "bracket planner options");
  if (darkest_frame.clipped_share <= options.clipped_share) return std::nullopt;
  const double step_stops =
      std::log2(options.saturation_fraction / options.min_signal_fraction) - options.overlap_stops;
  const double target = darkest.relative_exposure * std::exp2(-step_stops);
  if (caps.control == drivers::ExposureControl::kContinuous) {
    const double t = std::max(target * metering_exposure_time_s, caps.min_exposure_time_s);
    if (t >= darkest.exposure_time_s.value_or(INFINITY) * 0.999) return std::nullopt;
    PlannedExposure e;
    e.exposure_time_s = t;
    e.relative_exposure = t / metering_exposure_time_s;
    return e;
  }
  const std::vector<Choice> choices = DiscreteChoices(caps, metering_exposure_time_s, metering_ev);
  if (choices.empty()) return std::nullopt;
  const std::size_t index = Snap(choices, target, +1);  // no darker than one step: keep the overlap
  if (choices[index].relative >= darkest.relative_exposure * 0.999) {
    if (index == 0) return std::nullopt;
    return choices[index - 1].planned;
  }
  return choices[index].planned;
}

}  // namespace relume::capture
