#include "calibration/hdr_merge.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "calibration/bracket.h"
#include "core/error.h"
#include "core/parallel.h"

namespace relume::calibration {
namespace {

bool Fail(std::string* why, const std::string& reason) {
  if (why) *why = reason;
  return false;
}

// Per frame and channel: weighted radiance w(z) X(z) / t and weight w(z), indexed by code.
struct FrameTables {
  std::vector<float> weighted;  // [channel * levels + z]
  std::vector<float> weight;
  std::vector<float> value;  // X(z) / t, for the fallbacks
};

// Accumulates one frame's row into the running sums: a linear pass with two table lookups
// per sample, which pipelines better than looping over frames inside each pixel.
template <typename Sample>
void AccumulateRow(const Sample* row, const float* const* weighted, const float* const* weight, int cols, int channels,
                   int frame, float* num, float* den, std::uint16_t* mask) {
  if (channels == 3) {
    const float *v0 = weighted[0], *v1 = weighted[1], *v2 = weighted[2];
    const float *w0 = weight[0], *w1 = weight[1], *w2 = weight[2];
    for (int x = 0; x < cols; ++x) {
      const Sample* p = row + 3 * x;
      const float a = w0[p[0]], b = w1[p[1]], c = w2[p[2]];
      num[3 * x] += v0[p[0]];
      num[3 * x + 1] += v1[p[1]];
      num[3 * x + 2] += v2[p[2]];
      den[3 * x] += a;
      den[3 * x + 1] += b;
      den[3 * x + 2] += c;
      mask[x] =
          static_cast<std::uint16_t>(mask[x] | (static_cast<unsigned>((a > 0.0f) | (b > 0.0f) | (c > 0.0f)) << frame));
    }
  } else {
    const float* v = weighted[0];
    const float* w = weight[0];
    for (int x = 0; x < cols; ++x) {
      const float a = w[row[x]];
      num[x] += v[row[x]];
      den[x] += a;
      mask[x] = static_cast<std::uint16_t>(mask[x] | (static_cast<unsigned>(a > 0.0f) << frame));
    }
  }
}

template <typename Sample>
void MergeRows(const std::vector<const cv::Mat*>& frames, const std::vector<FrameTables>& tables, int levels,
               int channels, int shortest, int longest, int mid_code, int row_begin, int row_end, HdrMergeResult* out) {
  const int n = static_cast<int>(frames.size());
  // Raw table pointers per (frame, channel), hoisted out of the pixel loop.
  std::vector<const float*> weighted(static_cast<std::size_t>(n) * channels), weight(weighted.size());
  for (int j = 0; j < n; ++j) {
    for (int c = 0; c < channels; ++c) {
      weighted[j * channels + c] = tables[j].weighted.data() + static_cast<std::size_t>(c) * levels;
      weight[j * channels + c] = tables[j].weight.data() + static_cast<std::size_t>(c) * levels;
    }
  }
  const int cols = frames[0]->cols;
  std::vector<float> den(static_cast<std::size_t>(cols) * channels);
  for (int y = row_begin; y < row_end; ++y) {
    float* num = out->radiance.pixels.ptr<float>(y);  // sums in place, divided below
    std::uint16_t* bits = out->contributors.ptr<std::uint16_t>(y);
    std::uint8_t* status = out->status.ptr<std::uint8_t>(y);
    std::fill(num, num + den.size(), 0.0f);
    std::fill(den.begin(), den.end(), 0.0f);
    std::fill(bits, bits + cols, std::uint16_t{0});
    for (int j = 0; j < n; ++j) {
      AccumulateRow(frames[j]->ptr<Sample>(y), &weighted[j * channels], &weight[j * channels], cols, channels, j, num,
                    den.data(), bits);
    }
    const Sample* short_row = frames[shortest]->ptr<Sample>(y);
    const Sample* long_row = frames[longest]->ptr<Sample>(y);
    for (int x = 0; x < cols; ++x) {
      std::uint8_t st = kHdrGood;
      for (int c = 0; c < channels; ++c) {
        const std::size_t i = static_cast<std::size_t>(x) * channels + c;
        if (den[i] > 0.0f) {
          num[i] /= den[i];
        } else {
          // No well-exposed sample: the longest frame tells whether it is dark or bright.
          const bool dark = long_row[i] < mid_code;
          const int j = dark ? longest : shortest;
          num[i] = tables[j].value[static_cast<std::size_t>(c) * levels + (dark ? long_row[i] : short_row[i])];
          st = static_cast<std::uint8_t>(st | (dark ? kHdrBlackUpperBound : kHdrSaturatedLowerBound));
        }
      }
      status[x] = st;
    }
  }
}

}  // namespace

bool HdrMergeOptions::IsValid(std::string* why) const {
  if (black_margin < 0 || saturation_margin < 0) return Fail(why, "margins must be >= 0");
  if (threads < 0 || threads > 256) return Fail(why, "threads must be in [0, 256]");
  return true;
}

std::string HdrMergeSummary::BriefReport() const {
  std::ostringstream s;
  s << "merged " << frames << " frame(s), " << pixels << " pixels, " << pixels_saturated_everywhere
    << " saturated in every frame, " << pixels_black_everywhere << " black in every frame, " << threads_used
    << " thread(s)";
  if (!reason.empty()) s << " (" << reason << ")";
  return s.str();
}

CameraResponse SensorLinearResponse(const CameraImage& frame) {
  std::string why;
  if (!frame.IsValid(&why)) throw InvalidArgumentError("frame: " + why);
  const int levels = frame.pixels.depth() == CV_8U ? 256 : 65536;
  return CameraResponse::Linear(frame.pixels.channels(), levels, frame.black_level, frame.white_level);
}

HdrMergeResult MergeHdr(const std::vector<CameraImage>& frames, const std::vector<double>& exposure_times_s,
                        const CameraResponse& response, const HdrMergeOptions& options) {
  ThrowIfInvalid(options, "HDR merge options");
  CheckBracket(frames, exposure_times_s);
  if (frames.size() > 16) throw InvalidArgumentError("HDR merge takes at most 16 frames");
  std::string why;
  if (!response.IsValid(&why)) throw InvalidArgumentError("response: " + why);
  const CameraImage& first = frames.front();
  const int channels = first.pixels.channels();
  const int levels = first.pixels.depth() == CV_8U ? 256 : 65536;
  if (response.channels() != channels || response.levels != levels) {
    throw InvalidArgumentError("response has " + std::to_string(response.channels()) + " channel(s) and " +
                               std::to_string(response.levels) + " levels but the frames have " +
                               std::to_string(channels) + " channel(s) and " + std::to_string(levels) + " levels");
  }
  const int n = static_cast<int>(frames.size());
  // Weight range: codes strictly inside (black + margin, white - margin).
  const int lo = first.black_level + options.black_margin;
  const int hi = first.white_level - options.saturation_margin;
  const double half = std::max(1.0, (hi - lo) / 2.0);
  std::vector<FrameTables> tables(n);
  for (int j = 0; j < n; ++j) {
    const double t = exposure_times_s[j];
    const double scale = options.weight_by_exposure ? t : 1.0;
    FrameTables& tab = tables[j];
    tab.weighted.resize(static_cast<std::size_t>(channels) * levels);
    tab.weight.resize(tab.weighted.size());
    tab.value.resize(tab.weighted.size());
    for (int c = 0; c < channels; ++c) {
      for (int z = 0; z < levels; ++z) {
        const std::size_t k = static_cast<std::size_t>(c) * levels + z;
        const double hat = (z <= lo || z >= hi) ? 0.0 : std::min(z - lo, hi - z) / half;
        const double value = response.inverse[c][z] / t;
        tab.weight[k] = static_cast<float>(hat * scale);
        tab.weighted[k] = static_cast<float>(hat * scale * value);
        tab.value[k] = static_cast<float>(value);
      }
    }
  }
  // Weights are relative: normalise so the largest is 1 (keeps float sums well scaled).
  float wmax = 0.0f;
  for (const auto& tab : tables) wmax = std::max(wmax, *std::max_element(tab.weight.begin(), tab.weight.end()));
  if (wmax > 0.0f) {
    for (auto& tab : tables) {
      for (auto& w : tab.weight) w /= wmax;
      for (auto& w : tab.weighted) w /= wmax;
    }
  }
  const std::vector<int> order = OrderByExposure(exposure_times_s);
  std::vector<const cv::Mat*> mats;
  for (const auto& f : frames) mats.push_back(&f.pixels);

  HdrMergeResult out;
  out.radiance.pixels = cv::Mat(first.pixels.size(), CV_MAKETYPE(CV_32F, channels));
  out.radiance.unit = RadianceUnit::kRelative;
  out.contributors = cv::Mat(first.pixels.size(), CV_16UC1);
  out.status = cv::Mat(first.pixels.size(), CV_8UC1);
  const int rows = first.height();
  // At least 8 rows per thread: a thread costs more than merging a few rows.
  constexpr int kMinRowsPerThread = 8;
  const int mid_code = (first.black_level + first.white_level) / 2;
  auto work = [&](std::int64_t begin, std::int64_t end) {
    const int b = static_cast<int>(begin), e = static_cast<int>(end);
    if (levels == 256) {
      MergeRows<std::uint8_t>(mats, tables, levels, channels, order.front(), order.back(), mid_code, b, e, &out);
    } else {
      MergeRows<std::uint16_t>(mats, tables, levels, channels, order.front(), order.back(), mid_code, b, e, &out);
    }
  };
  ParallelFor(0, rows, work, options.threads, kMinRowsPerThread);
  HdrMergeSummary& s = out.summary;
  s.frames = n;
  s.threads_used = ParallelThreads(0, rows, options.threads, kMinRowsPerThread);
  s.pixels = static_cast<long long>(first.pixels.total());
  for (int y = 0; y < rows; ++y) {
    const std::uint8_t* st = out.status.ptr<std::uint8_t>(y);
    for (int x = 0; x < first.width(); ++x) {
      if (st[x] & kHdrSaturatedLowerBound) ++s.pixels_saturated_everywhere;
      if (st[x] & kHdrBlackUpperBound) ++s.pixels_black_everywhere;
    }
  }
  if (s.pixels_saturated_everywhere > 0) {
    s.reason = std::to_string(s.pixels_saturated_everywhere) +
               " pixel(s) saturated in every frame hold lower bounds; add a shorter exposure";
  }
  if (s.pixels_black_everywhere > 0) {
    s.reason += std::string(s.reason.empty() ? "" : "; ") + std::to_string(s.pixels_black_everywhere) +
                " pixel(s) black in every frame hold upper bounds; add a longer exposure";
  }
  return out;
}

}  // namespace relume::calibration
