#include "calibration/colorchecker_detect.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/mcc.hpp>

#include "core/error.h"

#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/lsan_interface.h>
#endif

namespace relume::calibration {
namespace {

bool Fail(std::string* why, const std::string& reason) {
  if (why) *why = reason;
  return false;
}

const std::array<cv::Point2f, 4> kGridCorners = {cv::Point2f(0, 0), cv::Point2f(6, 0), cv::Point2f(6, 4),
                                                 cv::Point2f(0, 4)};

cv::Matx33d ImageFromGridMatrix(const std::array<cv::Point2f, 4>& corners) {
  std::vector<cv::Point2f> grid(kGridCorners.begin(), kGridCorners.end());
  std::vector<cv::Point2f> image(corners.begin(), corners.end());
  return cv::Matx33d(cv::getPerspectiveTransform(grid, image));
}

cv::Point2f Apply(const cv::Matx33d& h, cv::Point2f p) {
  const cv::Vec3d q = h * cv::Vec3d(p.x, p.y, 1.0);
  return {static_cast<float>(q[0] / q[2]), static_cast<float>(q[1] / q[2])};
}

// Orders four points around their centroid, clockwise on screen (y down), starting anywhere.
std::array<cv::Point2f, 4> OrderAround(const std::vector<cv::Point2f>& points) {
  cv::Point2f centre(0, 0);
  for (const auto& p : points) centre += p * 0.25f;
  std::vector<cv::Point2f> sorted = points;
  std::sort(sorted.begin(), sorted.end(), [&](const cv::Point2f& a, const cv::Point2f& b) {
    return std::atan2(a.y - centre.y, a.x - centre.x) < std::atan2(b.y - centre.y, b.x - centre.x);
  });
  return {sorted[0], sorted[1], sorted[2], sorted[3]};
}

std::vector<double> Ranks(const std::vector<double>& v) {
  std::vector<int> idx(v.size());
  std::iota(idx.begin(), idx.end(), 0);
  std::sort(idx.begin(), idx.end(), [&](int a, int b) { return v[a] < v[b]; });
  std::vector<double> r(v.size());
  for (std::size_t i = 0; i < idx.size(); ++i) r[idx[i]] = static_cast<double>(i);
  return r;
}

double Pearson(const std::vector<double>& a, const std::vector<double>& b) {
  const double n = static_cast<double>(a.size());
  const double ma = std::accumulate(a.begin(), a.end(), 0.0) / n, mb = std::accumulate(b.begin(), b.end(), 0.0) / n;
  double sab = 0, saa = 0, sbb = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    sab += (a[i] - ma) * (b[i] - mb);
    saa += (a[i] - ma) * (a[i] - ma);
    sbb += (b[i] - mb) * (b[i] - mb);
  }
  return saa > 0 && sbb > 0 ? sab / std::sqrt(saa * sbb) : 0.0;
}

// How well the patches under a candidate orientation match the reference: rank correlation
// of brightness (response independent) plus correlation of chromaticities.
double OrientationScore(const std::array<cv::Point2f, 4>& corners, const cv::Mat& rgb8,
                        const ColorCheckerReference& reference) {
  ChartLocation loc;
  loc.found = true;
  loc.corners = corners;
  ChartImage image;
  rgb8.convertTo(image.values, CV_32FC3, 1.0 / 255.0);
  PatchSampleOptions options;
  options.samples_per_side = 5;
  const std::vector<PatchSample> patches = SamplePatches(image, loc, options);
  std::vector<double> lum_m, lum_r, chroma_m, chroma_r;
  for (int k = 0; k < 24; ++k) {
    const cv::Vec3d& m = patches[k].median;
    const LinearRgb& r = reference.patches[k].linear_rgb;
    const double sm = m[0] + m[1] + m[2] + 1e-9, sr = r.sum() + 1e-9;
    lum_m.push_back(0.2126 * m[0] + 0.7152 * m[1] + 0.0722 * m[2]);
    lum_r.push_back(0.2126 * r.x() + 0.7152 * r.y() + 0.0722 * r.z());
    chroma_m.insert(chroma_m.end(), {m[0] / sm, m[2] / sm});
    chroma_r.insert(chroma_r.end(), {r.x() / sr, r.z() / sr});
  }
  return Pearson(Ranks(lum_m), Ranks(lum_r)) + Pearson(chroma_m, chroma_r);
}

// Tries the four cyclic assignments of an ordered quad to the grid corners.
ChartLocation Orient(const std::array<cv::Point2f, 4>& ordered, const cv::Mat& rgb8,
                     const ColorCheckerReference& reference, const std::string& method) {
  ChartLocation best;
  best.method = method;
  best.orientation_score = -1e9;
  for (int start = 0; start < 4; ++start) {
    std::array<cv::Point2f, 4> c;
    for (int k = 0; k < 4; ++k) c[k] = ordered[(start + k) % 4];
    const double score = OrientationScore(c, rgb8, reference);
    if (score > best.orientation_score) {
      best.orientation_score = score;
      best.corners = c;
    }
  }
  best.found = best.orientation_score > 1.0;
  if (!best.found) {
    best.reason = method + ": the outlined region does not look like a ColorChecker (orientation score " +
                  std::to_string(best.orientation_score) + " <= 1)";
  }
  return best;
}

ChartLocation DetectWithMcc(const cv::Mat& rgb8, const ColorCheckerReference& reference) {
  cv::Mat bgr;
  cv::cvtColor(rgb8, bgr, cv::COLOR_RGB2BGR);
#if defined(__SANITIZE_ADDRESS__)
  // Debian's OpenCV 4.6 mcc module leaks its own buffers (~4.7 MB per detection, found by
  // LeakSanitizer); only its allocations are exempted from leak reports.
  // LeakSanitizer's exemption is per thread, so mcc runs on this thread only in these builds.
  __lsan::ScopedDisabler mcc_leaks_are_opencvs;
  struct SingleThreaded {
    int threads = cv::getNumThreads();
    SingleThreaded() { cv::setNumThreads(1); }
    ~SingleThreaded() { cv::setNumThreads(threads); }
  } single_threaded;
#endif
  cv::Ptr<cv::mcc::CCheckerDetector> detector = cv::mcc::CCheckerDetector::create();
  ChartLocation none;
  none.method = "mcc";
  if (!detector->process(bgr, cv::mcc::MCC24, 1)) {
    none.reason = "mcc: no chart found";
    return none;
  }
  cv::Ptr<cv::mcc::CChecker> checker = detector->getBestColorChecker();
  if (!checker) {
    none.reason = "mcc: no chart found";
    return none;
  }
  const std::vector<cv::Point2f> box = checker->getBox();
  if (box.size() != 4) {
    none.reason = "mcc: the chart outline does not have 4 corners";
    return none;
  }
  return Orient(OrderAround(box), rgb8, reference, "mcc");
}

struct Square {
  cv::Point2f centre;
  double side = 0.0;
  double angle_rad = 0.0;  // of one side, folded into [0, pi/2)
};

// Squares in the image: convex quadrilaterals with near-equal sides, from thresholds at
// several levels (patches are brighter or darker than the chart body around them).
std::vector<Square> FindSquares(const cv::Mat& gray, int min_side) {
  std::vector<Square> squares;
  for (int block : {15, 31, 61}) {
    for (int sign : {1, -1}) {
      cv::Mat binary;
      cv::adaptiveThreshold(gray, binary, 255, cv::ADAPTIVE_THRESH_MEAN_C,
                            sign > 0 ? cv::THRESH_BINARY : cv::THRESH_BINARY_INV, block, 3 * sign);
      cv::morphologyEx(binary, binary, cv::MORPH_OPEN, cv::Mat::ones(3, 3, CV_8U));
      std::vector<std::vector<cv::Point>> contours;
      cv::findContours(binary, contours, cv::RETR_LIST, cv::CHAIN_APPROX_SIMPLE);
      for (const auto& contour : contours) {
        const double area = cv::contourArea(contour);
        if (area < min_side * min_side) continue;
        const cv::RotatedRect rect = cv::minAreaRect(contour);
        const double w = rect.size.width, h = rect.size.height;
        if (std::min(w, h) < min_side || std::max(w, h) > 1.4 * std::min(w, h)) continue;
        if (area < 0.8 * w * h) continue;  // not filled like a square
        Square s;
        s.centre = rect.center;
        s.side = std::sqrt(area);
        s.angle_rad = std::fmod(rect.angle * CV_PI / 180.0 + 2 * CV_PI, CV_PI / 2);
        squares.push_back(s);
      }
    }
  }
  return squares;
}

// Relume's own detector: squares of one size on a regular lattice, 6 x 4 of them.
ChartLocation DetectWithLattice(const cv::Mat& rgb8, const ColorCheckerReference& reference,
                                const ChartDetectOptions& options) {
  ChartLocation none;
  none.method = "lattice";
  cv::Mat gray;
  cv::cvtColor(rgb8, gray, cv::COLOR_RGB2GRAY);
  std::vector<Square> squares = FindSquares(gray, options.min_patch_side_px);
  if (squares.size() < 6) {
    none.reason = "lattice: fewer than 6 square patches found";
    return none;
  }
  // Keep the size class with most members, then merge duplicates from different thresholds.
  int best = 0, best_count = 0;
  for (std::size_t i = 0; i < squares.size(); ++i) {
    int count = 0;
    for (const auto& s : squares) count += std::abs(std::log(s.side / squares[i].side)) < 0.25 ? 1 : 0;
    if (count > best_count) {
      best_count = count;
      best = static_cast<int>(i);
    }
  }
  const double side = squares[best].side;
  std::vector<Square> unique;
  for (const auto& s : squares) {
    if (std::abs(std::log(s.side / side)) >= 0.25) continue;
    bool duplicate = false;
    for (const auto& u : unique) duplicate = duplicate || cv::norm(u.centre - s.centre) < 0.4 * side;
    if (!duplicate) unique.push_back(s);
  }
  if (unique.size() < 12) {
    none.reason = "lattice: only " + std::to_string(unique.size()) + " patch-sized squares found (need 12)";
    return none;
  }
  // Lattice pitch: median nearest-neighbour distance; axes from the median square angle.
  std::vector<double> nearest, angles;
  for (const auto& a : unique) {
    double d = 1e30;
    for (const auto& b : unique) {
      if (&a != &b) d = std::min(d, cv::norm(a.centre - b.centre));
    }
    nearest.push_back(d);
    angles.push_back(a.angle_rad);
  }
  std::nth_element(nearest.begin(), nearest.begin() + nearest.size() / 2, nearest.end());
  std::nth_element(angles.begin(), angles.begin() + angles.size() / 2, angles.end());
  const double pitch = nearest[nearest.size() / 2];
  const double theta = angles[angles.size() / 2];
  const cv::Point2f u(static_cast<float>(pitch * std::cos(theta)), static_cast<float>(pitch * std::sin(theta)));
  const cv::Point2f v(-u.y, u.x);
  // Integer lattice coordinates relative to the square nearest the centroid, then a
  // homography from lattice to image, refined twice with re-rounded coordinates.
  cv::Point2f centroid(0, 0);
  for (const auto& s : unique) centroid += s.centre * (1.0f / unique.size());
  const Square& origin = *std::min_element(unique.begin(), unique.end(), [&](const Square& a, const Square& b) {
    return cv::norm(a.centre - centroid) < cv::norm(b.centre - centroid);
  });
  std::vector<cv::Point2f> lattice(unique.size()), image(unique.size());
  for (std::size_t i = 0; i < unique.size(); ++i) {
    const cv::Point2f d = unique[i].centre - origin.centre;
    lattice[i] = {static_cast<float>(std::round(d.dot(u) / (pitch * pitch))),
                  static_cast<float>(std::round(d.dot(v) / (pitch * pitch)))};
    image[i] = unique[i].centre;
  }
  cv::Mat h;
  for (int round = 0; round < 3; ++round) {
    h = cv::findHomography(lattice, image, cv::RANSAC, 0.25 * pitch);
    if (h.empty()) {
      none.reason = "lattice: the squares do not form a lattice";
      return none;
    }
    const cv::Matx33d hinv = cv::Matx33d(h).inv();
    for (std::size_t i = 0; i < unique.size(); ++i) {
      const cv::Point2f q = Apply(hinv, image[i]);
      lattice[i] = {std::round(q.x), std::round(q.y)};
    }
  }
  // Keep squares that sit on lattice points; the chart must fill a 6 x 4 (or 4 x 6) block.
  const cv::Matx33d H(h);
  float min_i = 1e9f, max_i = -1e9f, min_j = 1e9f, max_j = -1e9f;
  int on_lattice = 0;
  for (std::size_t i = 0; i < unique.size(); ++i) {
    if (cv::norm(Apply(H, lattice[i]) - image[i]) > 0.25 * pitch) continue;
    ++on_lattice;
    min_i = std::min(min_i, lattice[i].x);
    max_i = std::max(max_i, lattice[i].x);
    min_j = std::min(min_j, lattice[i].y);
    max_j = std::max(max_j, lattice[i].y);
  }
  const int ni = static_cast<int>(max_i - min_i) + 1, nj = static_cast<int>(max_j - min_j) + 1;
  if (!((ni == 6 && nj == 4) || (ni == 4 && nj == 6)) || on_lattice < 12) {
    none.reason = "lattice: the squares span " + std::to_string(ni) + " x " + std::to_string(nj) +
                  " cells, not 6 x 4 (chart partly hidden, or other squares nearby)";
    return none;
  }
  // Outer corners of the block (cell centres are at integer lattice points).
  std::vector<cv::Point2f> quad = {Apply(H, {min_i - 0.5f, min_j - 0.5f}), Apply(H, {max_i + 0.5f, min_j - 0.5f}),
                                   Apply(H, {max_i + 0.5f, max_j + 0.5f}), Apply(H, {min_i - 0.5f, max_j + 0.5f})};
  ChartLocation found = Orient(OrderAround(quad), rgb8, reference, "lattice");
  if (found.found) found.reason = std::to_string(on_lattice) + " of 24 patches seen as squares";
  return found;
}

}  // namespace

const char* ToString(ChartDetector detector) {
  switch (detector) {
    case ChartDetector::kAuto: return "auto";
    case ChartDetector::kMcc: return "mcc";
    case ChartDetector::kLattice: return "lattice";
  }
  return "unknown";
}

ChartDetector ChartDetectorFromString(const std::string& name) {
  if (name == "auto") return ChartDetector::kAuto;
  if (name == "mcc") return ChartDetector::kMcc;
  if (name == "lattice") return ChartDetector::kLattice;
  throw InvalidArgumentError("chart detector '" + name + "' is unknown; use auto, mcc or lattice");
}

bool ChartDetectOptions::IsValid(std::string* why) const {
  if (min_patch_side_px < 3) return Fail(why, "min_patch_side_px must be >= 3");
  return true;
}

bool PatchSampleOptions::IsValid(std::string* why) const {
  if (!(inner_fraction > 0.05 && inner_fraction <= 0.8)) return Fail(why, "inner_fraction must be in (0.05, 0.8]");
  if (samples_per_side < 2 || samples_per_side > 100) return Fail(why, "samples_per_side must be in [2, 100]");
  if (!(max_spread > 0.0)) return Fail(why, "max_spread must be > 0");
  return true;
}

const char* ToString(PatchStatus status) {
  switch (status) {
    case PatchStatus::kOk: return "ok";
    case PatchStatus::kSaturated: return "saturated";
    case PatchStatus::kBlack: return "black";
    case PatchStatus::kNonUniform: return "non-uniform";
    case PatchStatus::kOutside: return "outside";
  }
  return "unknown";
}

ChartLocation DetectColorChecker(const cv::Mat& rgb8, const ColorCheckerReference& reference,
                                 const ChartDetectOptions& options) {
  ThrowIfInvalid(options, "chart detection options");
  if (rgb8.type() != CV_8UC3) throw InvalidArgumentError("chart detection needs an 8-bit RGB image");
  RELUME_CHECK(reference.patches.size() == 24);
  std::string notes;
  if (options.detector != ChartDetector::kLattice) {
    ChartLocation mcc = DetectWithMcc(rgb8, reference);
    if (mcc.found || options.detector == ChartDetector::kMcc) return mcc;
    notes = mcc.reason + "; ";
  }
  ChartLocation lattice = DetectWithLattice(rgb8, reference, options);
  lattice.reason = notes + lattice.reason;
  return lattice;
}

ChartLocation ChartFromCorners(const std::vector<cv::Point2f>& points, const cv::Mat& rgb8,
                               const ColorCheckerReference& reference) {
  if (points.size() != 4) {
    throw InvalidArgumentError("chart corners: need exactly 4 points (x,y pairs), got " +
                               std::to_string(points.size()));
  }
  for (const auto& p : points) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) throw InvalidArgumentError("chart corners: a corner is not finite");
  }
  const std::array<cv::Point2f, 4> ordered = OrderAround(points);
  std::vector<cv::Point2f> poly(ordered.begin(), ordered.end());
  if (!cv::isContourConvex(poly) || cv::contourArea(poly) < 100.0) {
    throw InvalidArgumentError("chart corners: the 4 points do not enclose a convex area of at least 100 pixels");
  }
  ChartLocation loc = Orient(ordered, rgb8, reference, "manual");
  if (!loc.found) {
    // The user said where the chart is: keep the best orientation, flagged.
    loc.found = true;
    loc.reason = "manual corners: orientation uncertain (score " + std::to_string(loc.orientation_score) + ")";
  }
  return loc;
}

ChartImage ChartImageFromCamera(const CameraImage& image, int margin) {
  std::string why;
  if (!image.IsValid(&why)) throw InvalidArgumentError("chart image: " + why);
  if (image.layout != ColorLayout::kRgb) throw InvalidArgumentError("chart image must be RGB (demosaic raw first)");
  ChartImage out;
  const double range = image.white_level - image.black_level;
  image.pixels.convertTo(out.values, CV_32FC3, 1.0 / range, -image.black_level / range);
  out.clipped = cv::Mat::zeros(image.pixels.size(), CV_8UC1);
  cv::Mat channels[3];
  cv::split(image.pixels, channels);
  for (const cv::Mat& c : channels) {
    cv::Mat high = c >= image.white_level - margin;
    cv::Mat low = c <= image.black_level + margin;
    out.clipped.setTo(1, high);
    out.clipped.setTo(2, low & (out.clipped == 0));
  }
  return out;
}

cv::Point2f ImageFromGrid(const ChartLocation& location, cv::Point2f grid) {
  return Apply(ImageFromGridMatrix(location.corners), grid);
}

std::vector<PatchSample> SamplePatches(const ChartImage& image, const ChartLocation& location,
                                       const PatchSampleOptions& options) {
  ThrowIfInvalid(options, "patch sampling options");
  RELUME_CHECK(image.values.type() == CV_32FC3);
  const cv::Matx33d h = ImageFromGridMatrix(location.corners);
  std::vector<PatchSample> patches(24);
  const int n = options.samples_per_side;
  const double half = options.inner_fraction / 2;
  for (int k = 0; k < 24; ++k) {
    PatchSample& patch = patches[k];
    const cv::Point2f centre(k % 6 + 0.5f, k / 6 + 0.5f);
    const float hf = static_cast<float>(half);
    patch.inner_quad = {Apply(h, centre + cv::Point2f(-hf, -hf)), Apply(h, centre + cv::Point2f(hf, -hf)),
                        Apply(h, centre + cv::Point2f(hf, hf)), Apply(h, centre + cv::Point2f(-hf, hf))};
    std::array<std::vector<double>, 3> values;
    bool saturated = false, black = false, outside = false;
    for (int a = 0; a < n; ++a) {
      for (int b = 0; b < n; ++b) {
        const cv::Point2f g = centre + cv::Point2f(static_cast<float>(-half + 2 * half * (a + 0.5) / n),
                                                   static_cast<float>(-half + 2 * half * (b + 0.5) / n));
        const cv::Point2f p = Apply(h, g);
        const int x = static_cast<int>(std::floor(p.x)), y = static_cast<int>(std::floor(p.y));
        if (x < 0 || y < 0 || x >= image.values.cols || y >= image.values.rows) {
          outside = true;
          continue;
        }
        if (!image.clipped.empty()) {
          const std::uint8_t c = image.clipped.at<std::uint8_t>(y, x);
          saturated = saturated || c == 1;
          black = black || c == 2;
        }
        const cv::Vec3f v = image.values.at<cv::Vec3f>(y, x);
        for (int c = 0; c < 3; ++c) values[c].push_back(v[c]);
      }
    }
    if (values[0].empty()) {
      patch.status = PatchStatus::kOutside;
      continue;
    }
    for (int c = 0; c < 3; ++c) {
      auto& v = values[c];
      std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
      const double median = v[v.size() / 2];
      patch.median[c] = median;
      std::vector<double> dev;
      for (double x : v) dev.push_back(std::abs(x - median));
      std::nth_element(dev.begin(), dev.begin() + dev.size() / 2, dev.end());
      if (median > 0) patch.spread = std::max(patch.spread, dev[dev.size() / 2] / median);
    }
    if (outside) {
      patch.status = PatchStatus::kOutside;
    } else if (saturated) {
      patch.status = PatchStatus::kSaturated;
    } else if (black) {
      patch.status = PatchStatus::kBlack;
    } else if (patch.spread > options.max_spread) {
      patch.status = PatchStatus::kNonUniform;
    }
  }
  return patches;
}

}  // namespace relume::calibration
