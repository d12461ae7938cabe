// The `radiosity` pipeline: per-patch albedo of a room from photographs under a moving lamp
// (Loscos et al.: EV-only HDR, radiance consistency scales, reflectance iterated with a
// radiosity solution; confidence weights after Debevec et al.), the converged radiosity
// solution, and a relit rendering under a lamp placed from the command line.
//
// Stages (each cached by a StageKey; docs/radiosity.md lists the files):
//   radiance (per bracket, radiance.h) -> radiosity-geometry (patches, pixel -> patch map)
//   -> radiosity-observe (per bracket: mean radiance per patch) -> radiosity-scale (absolute
//   scale of bracket 0) -> [planner: indirect share vs tolerance] -> radiosity-reflectance
//   (iterations, albedo, solution, plots) -> radiosity-relight (new lamp).
#include "pipeline/radiosity_pipeline.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <map>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <sstream>

#include "calibration/image_file.h"
#include "calibration/response.h"
#include "core/error.h"
#include "pipeline/radiance.h"
#include "pipeline/radiosity_scene.h"
#include "processing/radiosity/direct_light.h"
#include "processing/radiosity/reference_scale.h"
#include "processing/radiosity/reflectance.h"
#include "processing/radiosity/relight.h"

namespace relume::pipeline {
namespace fs = std::filesystem;
using radiosity::Rgb;

namespace {

struct Knobs {
  double patch_edge_m = 1.0;
  int form_factor_rays = 4;
  double bf_epsilon = 2e-3;
  // At most; iterating stops when no albedo changes by more than `tolerance` (issue 26: a fixed 4
  // stopped rooms of brighter walls unconverged). The summary says when the cap was reached.
  int iterations = 30;
  double tolerance = 0.01;  // albedo change that stops iterating; indirect share below it skips radiosity
  double residual_tolerance = 1e-3;
  int direct_samples = 4;
  int min_patch_pixels = 4;
  // Divide each patch's mean pixel radiance by the direct light averaged over the same pixels'
  // surface points (true), or over samples spread on the patch (false, the per-patch model).
  bool direct_at_pixels = true;
  // auto: a chart's (known-albedo materials of the scene model) when the first bracket sees one,
  // else none. chart: required. truth: the simulated world's radiance (an evaluation oracle).
  std::string scale = "auto";
  std::string material_groups;   // "a+b,c+d": objects known to share a material
  std::string input = "camera";  // camera | truth (the world's rendered radiance: no camera, noise-free)
  bool compare_truth = true;
  // A truth made outside relume (docs/radiosity.md): DIR/albedo.json (material or object name ->
  // [r, g, b]) and optionally DIR/relit.exr with DIR/relit.json (the camera's view under the
  // relighting lamp: {"light_m": [x, y, z], "light_intensity_w_sr": I}).
  std::string truth_dir;
  Eigen::Vector3d light_m{1.0, -1.0, 2.2};
  double light_intensity_w_sr = 30.0;

  template <typename V>
  void VisitKnobs(V& v) {
    v.Knob("patch_edge_m", patch_edge_m, "largest patch edge (m)", {"geometry"});
    v.Knob("material_groups", material_groups, "objects known to share a material: \"a+b,c+d\"", {"geometry"});
    v.Knob("min_patch_pixels", min_patch_pixels, "pixels a patch needs to be observed", {"observe"});
    v.Knob("input", input, "camera, or truth (the world's radiance: no camera, noise-free)", {"observe", "scale"});
    v.Knob("scale", scale, "absolute scale of the first bracket: auto, chart, none, or truth (simulation oracle)",
           {"scale"});
    v.Knob("iterations", iterations, "reflectance iterations at most", {"reflectance"});
    v.Knob("tolerance", tolerance, "albedo change that stops iterating; an indirect share below it skips radiosity",
           {"reflectance"});
    v.Knob("form_factor_rays", form_factor_rays, "visibility rays per form factor", {"reflectance"});
    v.Knob("bf_epsilon", bf_epsilon, "refinement threshold of the patch hierarchy (B F)", {"reflectance"});
    v.Knob("residual_tolerance", residual_tolerance, "radiosity solve's relative residual", {"reflectance"});
    v.Knob("direct_samples", direct_samples, "direct-light samples per patch", {"reflectance"});
    v.Knob("direct_at_pixels", direct_at_pixels,
           "direct light averaged over the observed pixels' surface points (false: over the patch)", {"reflectance"});
    v.Knob("compare_truth", compare_truth, "albedo errors against the simulated world per iteration", {"reflectance"});
    v.Knob("truth_dir", truth_dir, "compare with a truth made outside relume: albedo.json [, relit.exr + relit.json]",
           {"reflectance", "relight"});
    v.Knob("light_x", light_m.x(), "relighting lamp position, east (m)", {"relight"});
    v.Knob("light_y", light_m.y(), "relighting lamp position, north (m)", {"relight"});
    v.Knob("light_z", light_m.z(), "relighting lamp position, up (m)", {"relight"});
    v.Knob("light_intensity", light_intensity_w_sr, "relighting lamp intensity (W/sr)", {"relight"});
  }
};

Knobs ReadRadiosityKnobs(PipelineRun& run) {
  const Knobs k = run.ReadKnobs<Knobs>();
  auto bad = [](const std::string& what) { throw InvalidArgumentError("radiosity pipeline: " + what); };
  if (!(k.patch_edge_m >= 0.05 && k.patch_edge_m <= 10.0)) bad("--set patch_edge_m must be in [0.05, 10] metres");
  if (k.form_factor_rays < 1 || k.form_factor_rays > 256) bad("--set form_factor_rays must be in [1, 256]");
  if (!(k.bf_epsilon > 0.0 && k.bf_epsilon < 1.0)) bad("--set bf_epsilon must be in (0, 1)");
  if (k.iterations < 0 || k.iterations > 100) bad("--set iterations must be in [0, 100]");
  if (!(k.tolerance > 0.0)) bad("--set tolerance must be > 0 (albedo change / indirect share)");
  if (!(k.residual_tolerance > 0.0 && k.residual_tolerance < 1.0)) bad("--set residual_tolerance must be in (0, 1)");
  if (k.direct_samples < 1 || k.direct_samples > 256) bad("--set direct_samples must be in [1, 256]");
  if (k.min_patch_pixels < 1) bad("--set min_patch_pixels must be >= 1");
  if (k.scale != "auto" && k.scale != "chart" && k.scale != "truth" && k.scale != "none") {
    bad("--set scale must be auto, chart, none or truth (docs/radiosity.md)");
  }
  if (k.input != "camera" && k.input != "truth") bad("--set input must be camera or truth (docs/radiosity.md)");
  if (!(k.light_intensity_w_sr >= 0.0)) bad("--set light_intensity must be >= 0 (W/sr)");
  return k;
}

// ---- small file helpers -------------------------------------------------------------------

// Per-patch RGB values as CSV: "patch,<name>_r,<name>_g,<name>_b[,extra...]".
void WritePatchRgb(const fs::path& path, const std::string& name, const std::vector<Rgb>& values,
                   const std::vector<int>* counts = nullptr) {
  std::ofstream out(path);
  out << "patch," << name << "_r," << name << "_g," << name << "_b" << (counts ? ",pixels" : "") << "\n";
  char line[160];
  for (size_t p = 0; p < values.size(); ++p) {
    std::snprintf(line, sizeof(line), "%zu,%.9g,%.9g,%.9g", p, values[p].x(), values[p].y(), values[p].z());
    out << line;
    if (counts) out << "," << (*counts)[p];
    out << "\n";
  }
}

std::vector<Rgb> ReadPatchRgb(const fs::path& path, int patches) {
  std::ifstream in(path);
  if (!in) throw IoError(path.string(), "cannot read (stage output missing; rerun with --force)");
  std::string line;
  std::getline(in, line);
  std::vector<Rgb> values;
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string field;
    std::vector<double> f;
    while (std::getline(ss, field, ',')) f.push_back(std::strtod(field.c_str(), nullptr));
    if (f.size() < 4) throw IoError(path.string(), "malformed line '" + line + "'");
    values.emplace_back(f[1], f[2], f[3]);
  }
  if (static_cast<int>(values.size()) != patches) {
    throw IoError(path.string(), "has " + std::to_string(values.size()) + " patches, expected " +
                                     std::to_string(patches) + " (rerun with --force)");
  }
  return values;
}

// A per-pixel map as raw bytes: width, height (int32), then the rows. `type` is the OpenCV type
// the reader expects (the patch id map is CV_32SC1, the pixel points CV_32FC3).
void WritePixelMap(const fs::path& path, const cv::Mat& map) {
  std::ofstream out(path, std::ios::binary);
  const std::int32_t size[2] = {map.cols, map.rows};
  out.write(reinterpret_cast<const char*>(size), sizeof(size));
  const auto row_bytes = static_cast<std::streamsize>(map.cols * map.elemSize());
  for (int y = 0; y < map.rows; ++y) out.write(reinterpret_cast<const char*>(map.ptr(y)), row_bytes);
}

cv::Mat ReadPixelMap(const fs::path& path, int type, const char* what) {
  std::ifstream in(path, std::ios::binary);
  std::int32_t size[2] = {0, 0};
  in.read(reinterpret_cast<char*>(size), sizeof(size));
  if (!in || size[0] <= 0 || size[1] <= 0) {
    throw IoError(path.string(), std::string("not a ") + what + " (rerun with --force)");
  }
  cv::Mat map(size[1], size[0], type);
  const auto row_bytes = static_cast<std::streamsize>(map.cols * map.elemSize());
  for (int y = 0; y < map.rows; ++y) in.read(reinterpret_cast<char*>(map.ptr(y)), row_bytes);
  if (!in) throw IoError(path.string(), std::string("truncated ") + what + " (rerun with --force)");
  return map;
}

// Per-patch values painted into the camera's pixels (NaN where no patch).
RadianceImage PaintPatches(const cv::Mat& ids, const std::vector<Rgb>& values) {
  RadianceImage image = MakeRadianceImage(ids.cols, ids.rows);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int y = 0; y < ids.rows; ++y) {
    const int* id = ids.ptr<int>(y);
    auto* px = image.pixels.ptr<cv::Vec3f>(y);
    for (int x = 0; x < ids.cols; ++x) {
      if (id[x] < 0) {
        px[x] = cv::Vec3f(nan, nan, nan);
        continue;
      }
      const Rgb& v = values[id[x]];
      px[x] = cv::Vec3f(static_cast<float>(v.x()), static_cast<float>(v.y()), static_cast<float>(v.z()));
    }
  }
  return image;
}

// ---- accuracy against the world's truth -----------------------------------------------------

// Materials are groups of scene objects with the same true albedo (e.g. opposite walls).
struct MaterialGroups {
  std::vector<std::string> names;
  std::vector<Rgb> truth;
  std::vector<int> group_of_patch;  // -1: unknown
};

// Mesh triangles grouped by their true albedo (`truth_of(t)`, nullopt: not evaluated): materials
// of equal albedo form one group named after its radiosity materials; patches take their root
// triangle's group.
MaterialGroups GroupByTruth(const radiosity::PatchHierarchy& h, const RadiosityScene& rs,
                            const std::function<std::optional<Rgb>(std::size_t)>& truth_of) {
  MaterialGroups g;
  std::vector<int> group_of_triangle(rs.triangle_object.size(), -1);
  for (std::size_t t = 0; t < rs.triangle_object.size(); ++t) {
    const std::optional<Rgb> truth = truth_of(t);
    if (!truth) continue;
    const std::string& name = rs.mesh.MaterialOf(static_cast<int>(t)).name;
    int found = -1;
    for (size_t i = 0; i < g.truth.size(); ++i) {
      if ((g.truth[i] - *truth).cwiseAbs().maxCoeff() < 1e-9) found = static_cast<int>(i);
    }
    if (found < 0) {
      found = static_cast<int>(g.truth.size());
      g.truth.push_back(*truth);
      g.names.push_back(name);
    } else if (("+" + g.names[found] + "+").find("+" + name + "+") == std::string::npos) {
      g.names[found] += "+" + name;
    }
    group_of_triangle[t] = found;
  }
  for (int p = 0; p < h.LeafCount(); ++p) g.group_of_patch.push_back(group_of_triangle[h.leaf(p).root]);
  return g;
}

// Evaluation only: the true albedo per mesh triangle from the session truth's object of the same
// name (its face's albedo where the object has one per face, e.g. a ColorChecker's patches).
MaterialGroups GroupPatches(const radiosity::PatchHierarchy& h, const RadiosityScene& rs, const SceneModel& model,
                            const SessionTruth& truth) {
  for (const SceneModelObject& model_object : model.objects) {
    if (!truth.Albedo(model_object.name, -1)) {
      throw InvalidArgumentError("compare_truth: scene model object '" + model_object.name +
                                 "' is not in the session's simulated world; --set compare_truth=false");
    }
  }
  return GroupByTruth(h, rs, [&](std::size_t t) -> std::optional<Rgb> {
    const std::optional<Eigen::Vector3d> albedo =
        truth.Albedo(model.objects[rs.triangle_object[t]].name, rs.triangle_face[t]);
    return Rgb(*albedo);
  });
}

// Evaluation only, from an external truth (truth_dir/albedo.json): the true albedo per mesh
// triangle by its radiosity material's name (a group, or a chart's patch "chart/white"), else its
// object's; triangles of neither are not evaluated.
MaterialGroups GroupPatchesFromTruth(const radiosity::PatchHierarchy& h, const RadiosityScene& rs,
                                     const SceneModel& model, const std::map<std::string, Rgb>& truth) {
  return GroupByTruth(h, rs, [&](std::size_t t) -> std::optional<Rgb> {
    auto it = truth.find(rs.mesh.MaterialOf(static_cast<int>(t)).name);
    if (it == truth.end()) it = truth.find(model.objects[rs.triangle_object[t]].name);
    if (it == truth.end()) return std::nullopt;
    return it->second;
  });
}

// Albedo estimates against their materials' true albedo, accumulated per material: mean
// |estimate - truth| (mean of the channels), the material mean and its spread (standard
// deviation over the estimates, mean of the channels). `unit` names what one estimate is
// (patches or pixels); materials with fewer than `min_count` estimates do not enter the maxima.
class MaterialErrors {
 public:
  explicit MaterialErrors(const MaterialGroups& g)
      : g_(g),
        err_(g.truth.size(), 0.0),
        sum_(g.truth.size(), Rgb::Zero()),
        sum2_(g.truth.size(), Rgb::Zero()),
        count_(g.truth.size(), 0) {}
  void Add(int material, const Rgb& albedo) {
    if (material < 0 || !albedo.allFinite()) return;
    const double e = (albedo - g_.truth[material]).cwiseAbs().mean();
    err_[material] += e;
    sum_[material] += albedo;
    sum2_[material] += albedo.cwiseProduct(albedo);
    ++count_[material];
    total_ += e;
    ++total_count_;
  }
  // `pixels`: one estimate is a pixel (else a patch).
  AlbedoErrorFigures Figures(bool pixels, long long min_count) const {
    AlbedoErrorFigures out;
    double max_spread = 0.0, max_mean_error = 0.0;
    for (size_t k = 0; k < g_.truth.size(); ++k) {
      if (count_[k] == 0) continue;
      const auto n = static_cast<double>(count_[k]);
      const Rgb mean = sum_[k] / n;
      const Rgb var = (sum2_[k] / n - mean.cwiseProduct(mean)).cwiseMax(0.0);
      const double spread = var.cwiseSqrt().mean();
      const double bias = (mean - g_.truth[k]).cwiseAbs().mean();
      if (count_[k] >= min_count) {
        max_spread = std::max(max_spread, spread);
        max_mean_error = std::max(max_mean_error, bias);
      }
      MaterialAlbedoError& m = out.materials.emplace_back();
      m.material = g_.names[k];
      m.truth = g_.truth[k];
      m.mean = mean;
      m.error_of_mean = bias;
      (pixels ? m.pixels : m.patches) = count_[k];
      m.mean_abs_error = err_[k] / n;
      m.spread_sd = spread;
    }
    out.mean_abs_error = total_count_ > 0 ? total_ / static_cast<double>(total_count_) : 0.0;
    out.max_error_of_material_mean = max_mean_error;  // bias, materials with >= min_count estimates
    out.max_spread_sd = max_spread;                   // likewise
    (pixels ? out.pixels : out.patches) = total_count_;
    return out;
  }

 private:
  const MaterialGroups& g_;
  std::vector<double> err_;
  std::vector<Rgb> sum_, sum2_;
  std::vector<long long> count_;
  double total_ = 0.0;
  long long total_count_ = 0;
};

// Per observed patch, over materials with >= 5 observed patches.
AlbedoErrorFigures AlbedoErrors(const MaterialGroups& g, const std::vector<Rgb>& albedo,
                                const std::vector<bool>& seen) {
  MaterialErrors errors(g);
  for (size_t p = 0; p < albedo.size(); ++p) {
    if (seen[p]) errors.Add(g.group_of_patch[p], albedo[p]);
  }
  return errors.Figures(/*pixels=*/false, 5);
}

// ---- convergence chart -----------------------------------------------------------------------

// A log-scale line chart of series over iterations (one colour each), with a legend.
cv::Mat LogChart(const std::vector<std::pair<std::string, std::vector<double>>>& series, const std::string& title) {
  const int w = 560, h = 360, left = 60, right = 20, top = 40, bottom = 40;
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(255, 255, 255));
  double lo = 1e300, hi = 0.0;
  size_t n = 0;
  for (const auto& [name, v] : series) {
    n = std::max(n, v.size());
    for (double x : v) {
      if (x > 0.0 && std::isfinite(x)) {
        lo = std::min(lo, x);
        hi = std::max(hi, x);
      }
    }
  }
  if (!(hi > 0.0)) {
    lo = 1e-3;
    hi = 1.0;
  }
  const double l0 = std::floor(std::log10(lo)), l1 = std::max(l0 + 1.0, std::ceil(std::log10(hi)));
  auto px = [&](size_t i) { return left + static_cast<int>((w - left - right) * (n > 1 ? double(i) / (n - 1) : 0.5)); };
  auto py = [&](double v) {
    const double t = (std::log10(std::max(v, std::pow(10.0, l0))) - l0) / (l1 - l0);
    return top + static_cast<int>((h - top - bottom) * (1.0 - t));
  };
  cv::rectangle(img, {left, top}, {w - right, h - bottom}, cv::Scalar(0, 0, 0));
  for (double e = l0; e <= l1; e += 1.0) {
    const int y = py(std::pow(10.0, e));
    cv::line(img, {left, y}, {w - right, y}, cv::Scalar(220, 220, 220));
    cv::putText(img, "1e" + std::to_string(static_cast<int>(e)), {5, y + 4}, cv::FONT_HERSHEY_SIMPLEX, 0.4,
                cv::Scalar(0, 0, 0));
  }
  for (size_t i = 0; i < n; ++i) {
    cv::putText(img, std::to_string(i), {px(i) - 4, h - bottom + 16}, cv::FONT_HERSHEY_SIMPLEX, 0.4,
                cv::Scalar(0, 0, 0));
  }
  cv::putText(img, "iteration", {w / 2 - 30, h - 6}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0));
  cv::putText(img, title, {left, 24}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0));
  const cv::Scalar colours[] = {{200, 40, 40}, {40, 40, 200}, {40, 150, 40}, {150, 40, 150}};
  for (size_t s = 0; s < series.size(); ++s) {
    const cv::Scalar c = colours[s % 4];
    std::vector<cv::Point> pts;
    for (size_t i = 0; i < series[s].second.size(); ++i) {
      if (std::isfinite(series[s].second[i])) pts.emplace_back(px(i), py(series[s].second[i]));
    }
    if (pts.size() > 1) cv::polylines(img, pts, false, c, 2);
    for (const cv::Point& p : pts) cv::circle(img, p, 3, c, cv::FILLED);
    cv::putText(img, series[s].first, {w - right - 220, top + 18 + 16 * static_cast<int>(s)}, cv::FONT_HERSHEY_SIMPLEX,
                0.45, c);
  }
  return img;
}

cv::Mat AlbedoPreview(const RadianceImage& albedo) {
  return RadiancePreview(albedo, 1.0);
}

// The simulated world's radiance at a bracket's time, seen by the bracket's camera (input=truth:
// what an ideal, noise-free, calibrated camera would record), cached as stage "truth-radiance".
BracketRadiance TruthRadiance(PipelineRun& run, const std::vector<capture::FrameRecord>& bracket,
                              const PinholeCamera& camera) {
  BracketRadiance out;
  out.device_id = bracket.front().device_id;
  out.bracket_id = bracket.front().bracket_id;
  out.utc = bracket.front().utc;
  for (const capture::FrameRecord& f : bracket) out.frame_ids.push_back(f.id);
  out.key.Add("stage", "truth-radiance-v1")
      .Add("truth", run.truth()->Key())
      .Add("device", out.device_id)
      .Add("utc", FormatIso8601(out.utc));
  const StageStore::Result stage = run.RunStage("truth-radiance", out.key, [&](const fs::path& dir) {
    const GroundTruth truth = run.truth()->Render(camera, out.utc);
    calibration::SaveRadianceExr(truth.radiance, (dir / "radiance.exr").string());
  });
  out.exr = stage.dir / "radiance.exr";
  out.radiance = calibration::LoadRadianceExr(out.exr.string());
  return out;
}

// ---- the pipeline --------------------------------------------------------------------------

// Pixels clear of its edges a chart patch needs to enter scale=chart.
constexpr int kMinReferencePixels = 3;

// The radiosity-geometry stage's result.
struct Geometry {
  RadiosityScene scene;
  std::unique_ptr<radiosity::PatchHierarchy> hierarchy;
  std::unique_ptr<RayCaster> caster;
  StageKey key;
  cv::Mat ids;
  cv::Mat points_m;  // CV_32FC3: where each pixel's ray meets its patch (NaN where ids is -1)
};

// Per patch, the surface points of the pixels whose radiance the observation averaged (the same
// selection as the radiosity-observe stage: a patch, a good status, finite radiance), for patches
// with an observation.
std::vector<std::vector<Eigen::Vector3f>> PixelPointsPerPatch(const Geometry& geo, const BracketRadiance& r,
                                                              const std::vector<Rgb>& observed) {
  std::vector<std::vector<Eigen::Vector3f>> points(observed.size());
  for (int y = 0; y < geo.ids.rows; ++y) {
    const int* id = geo.ids.ptr<int>(y);
    const auto* px = r.radiance.pixels.ptr<cv::Vec3f>(y);
    const auto* xyz = geo.points_m.ptr<cv::Vec3f>(y);
    const std::uint8_t* status = r.status.empty() ? nullptr : r.status.ptr<std::uint8_t>(y);
    for (int x = 0; x < geo.ids.cols; ++x) {
      if (id[x] < 0 || (status && status[x] != 0)) continue;
      if (!std::isfinite(px[x][0]) || !std::isfinite(px[x][1]) || !std::isfinite(px[x][2])) continue;
      if (!observed[id[x]].allFinite()) continue;
      const Eigen::Vector3f p(xyz[x][0], xyz[x][1], xyz[x][2]);
      if (p.allFinite()) points[id[x]].push_back(p);
    }
  }
  return points;
}

// Per-pixel reflectance: in each bracket s, pi k a_s L_s(x) / (E_direct,s(x) + I_s,p) with the
// direct light at the pixel's own surface point x and the indirect light of its patch p (the
// last iteration's), combined over brackets with the patches' confidence weights and clamped to
// [0, 1] like the patch albedo. NaN where no bracket gives an estimate. `k` is bracket 0's
// absolute scale; the library's a_s makes the others consistent with it.
RadianceImage PixelReflectance(const Geometry& geo, const std::vector<BracketRadiance>& radiance,
                               const std::vector<radiosity::RadianceObservation>& observations,
                               const radiosity::ReflectanceResult& result, double k,
                               const radiosity::DirectLightOptions& direct_options) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  RadianceImage out = MakeRadianceImage(geo.ids.cols, geo.ids.rows);
  out.pixels.setTo(cv::Scalar(nan, nan, nan));
  const radiosity::PatchHierarchy& h = *geo.hierarchy;
  for (int y = 0; y < geo.ids.rows; ++y) {
    for (int x = 0; x < geo.ids.cols; ++x) {
      const int p = geo.ids.at<int>(y, x);
      const cv::Vec3f xyz = geo.points_m.at<cv::Vec3f>(y, x);
      if (p < 0 || !std::isfinite(xyz[0])) continue;
      const Eigen::Vector3d point(xyz[0], xyz[1], xyz[2]);
      Rgb sum = Rgb::Zero();
      double weight = 0.0;
      for (size_t s = 0; s < radiance.size(); ++s) {
        const double w = result.image_weight[s][p];
        if (!(w > 0.0) || (!radiance[s].status.empty() && radiance[s].status.at<std::uint8_t>(y, x) != 0)) continue;
        const cv::Vec3f l = radiance[s].radiance.pixels.at<cv::Vec3f>(y, x);
        const Rgb observed(l[0], l[1], l[2]);
        if (!observed.allFinite()) continue;
        const Rgb e = radiosity::DirectIrradianceAtPoint(*geo.caster, observations[s].lighting, point, h.leaf(p).normal,
                                                         direct_options) +
                      result.image_indirect[s][p];
        if (!(e.minCoeff() > 0.0)) continue;
        const Rgb rho = (std::numbers::pi * k * result.image_scale[s] * observed).cwiseQuotient(e);
        if (!rho.allFinite()) continue;
        sum += w * rho;
        weight += w;
      }
      if (!(weight > 0.0)) continue;
      const Rgb rho = (sum / weight).cwiseMax(0.0).cwiseMin(1.0);
      out.pixels.at<cv::Vec3f>(y, x) =
          cv::Vec3f(static_cast<float>(rho.x()), static_cast<float>(rho.y()), static_cast<float>(rho.z()));
    }
  }
  return out;
}

// A per-pixel reflectance map against the true albedo of each pixel's material, over materials
// with >= 20 pixels.
AlbedoErrorFigures PixelAlbedoErrors(const MaterialGroups& g, const cv::Mat& ids, const RadianceImage& map) {
  MaterialErrors errors(g);
  for (int y = 0; y < ids.rows; ++y) {
    for (int x = 0; x < ids.cols; ++x) {
      const int p = ids.at<int>(y, x);
      if (p < 0) continue;
      const cv::Vec3f v = map.pixels.at<cv::Vec3f>(y, x);
      errors.Add(g.group_of_patch[p], Rgb(v[0], v[1], v[2]));
    }
  }
  return errors.Figures(/*pixels=*/true, 20);
}

radiosity::ReflectanceOptions ReflectanceOptionsFrom(const Knobs& k, bool skip_radiosity) {
  radiosity::ReflectanceOptions o;
  o.max_iterations = k.iterations;
  o.albedo_tolerance = k.tolerance;
  o.fit_image_scales = true;
  o.unseen_from_scene_mean = true;  // surfaces the camera never saw: the room's mean albedo  // EV-only (or any)
                                    // camera: brackets are made consistent (Loscos eq. 3)
  o.indirect_skip_tolerance = skip_radiosity ? 1e300 : 0.0;
  o.direct.samples_per_patch = k.direct_samples;
  o.radiosity.rays_per_form_factor = k.form_factor_rays;
  o.radiosity.bf_epsilon = k.bf_epsilon;
  o.radiosity.residual_tolerance = k.residual_tolerance;
  return o;
}

radiosity::RadiosityOptions SolverOptionsFrom(const Knobs& k) {
  radiosity::RadiosityOptions o;
  o.rays_per_form_factor = k.form_factor_rays;
  o.bf_epsilon = k.bf_epsilon;
  o.residual_tolerance = k.residual_tolerance;
  return o;
}

// ---- the stages ------------------------------------------------------------------------------

// albedo.json of an external truth: {"name": [r, g, b], ...}, values in [0, 1].
std::map<std::string, Rgb> ReadTruthAlbedo(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw IoError(path.string(), "cannot be read: --set truth_dir needs albedo.json (docs/radiosity.md)");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw InvalidArgumentError(path.string() + ": not JSON (" + e.what() + ")");
  }
  std::map<std::string, Rgb> out;
  if (!j.is_object()) throw InvalidArgumentError(path.string() + ": expected {\"name\": [r, g, b], ...}");
  for (const auto& [name, value] : j.items()) {
    if (!value.is_array() || value.size() != 3 || !value[0].is_number() || !value[1].is_number() ||
        !value[2].is_number()) {
      throw InvalidArgumentError(path.string() + ": '" + name + "' is not [r, g, b]");
    }
    const Rgb a(value[0].get<double>(), value[1].get<double>(), value[2].get<double>());
    if (!(a.minCoeff() >= 0.0 && a.maxCoeff() <= 1.0)) {
      throw InvalidArgumentError(path.string() + ": '" + name + "' is outside [0, 1]");
    }
    out[name] = a;
  }
  return out;
}

// What every stage reads: the knobs, the session's scene model (geometry, lamps, the camera), the
// one camera's still brackets, and, for simulated sessions, the world to compare against.
struct RadiosityInputs {
  Knobs knobs;
  SceneModel model;
  PinholeCamera camera;
  const SessionTruth* world = nullptr;  // evaluation and the truth modes only; null for real sessions
  // External truth (knobs.truth_dir): the true albedo per material or object name.
  std::map<std::string, Rgb> truth_albedo;
  std::string device;
  std::vector<std::vector<capture::FrameRecord>> brackets;
};

// The knobs, the scene model and the camera, checked before any stage runs.
RadiosityInputs ReadRadiosityInputs(PipelineRun& run) {
  RadiosityInputs in;
  in.knobs = ReadRadiosityKnobs(run);
  if (run.request().mesh) {
    throw InvalidArgumentError(
        "--mesh is not supported by the radiosity pipeline yet: it takes the geometry, its objects and the "
        "lamps from the session's scene model");
  }
  const SceneModel* model = run.scene_model();
  if (model == nullptr) {
    throw InvalidArgumentError("the radiosity pipeline needs the room's geometry and lamps, and session " +
                               run.session().dir().string() +
                               " has no scene model (`relume session info`): " + SceneModelAdvice(run.session().dir()));
  }
  if (model->lamps.empty()) {
    throw InvalidArgumentError(
        "the radiosity pipeline needs the lamps' positions and intensities, and the session's "
        "scene model has no lamp");
  }
  in.model = *model;
  in.brackets = StillBrackets(run.session(), run.request().source);
  if (in.brackets.empty()) throw InvalidArgumentError("the session has no still-camera frames to estimate albedo from");
  in.device = in.brackets.front().front().device_id;
  for (const auto& b : in.brackets) {
    if (b.front().device_id != in.device) {
      throw InvalidArgumentError("the radiosity pipeline takes one camera; the frames come from " + in.device +
                                 " and " + b.front().device_id + ": pick one with --source " + in.device + ":still");
    }
  }
  in.camera = run.RequireCamera(in.device, "the radiosity pipeline").camera;
  in.world = run.truth();
  if (in.world == nullptr) {
    if (in.knobs.input == "truth") {
      throw InvalidArgumentError(
          "--set input=truth takes the simulator's rendered radiance, and this session has no simulated world (a "
          "real capture): use input=camera");
    }
    if (in.knobs.scale == "truth") {
      throw InvalidArgumentError(
          "--set scale=truth takes the simulator's rendered radiance, and this session has no simulated world (a "
          "real capture): use scale=chart with a ColorChecker in view (docs/radiosity.md) or scale=none");
    }
    if (in.knobs.compare_truth && in.knobs.truth_dir.empty()) {
      in.knobs.compare_truth = false;
      run.Decide("radiosity", "note", "no simulated world in the session: nothing to compare the albedo against");
    }
  }
  if (!in.knobs.truth_dir.empty()) {
    in.truth_albedo = ReadTruthAlbedo(fs::path(in.knobs.truth_dir) / "albedo.json");
    in.knobs.compare_truth = true;
    run.Decide("radiosity", "note",
               "comparing with the external truth in " + in.knobs.truth_dir + " (" +
                   std::to_string(in.truth_albedo.size()) + " materials' albedo)");
  }
  return in;
}

// patches.csv: per patch its object, centroid, normal and area.
void WritePatchesCsv(const fs::path& path, const radiosity::PatchHierarchy& h) {
  std::ofstream out(path);
  out << "patch,object,centroid_x_m,centroid_y_m,centroid_z_m,normal_x,normal_y,normal_z,area_m2\n";
  for (int p = 0; p < h.LeafCount(); ++p) {
    const radiosity::Node& node = h.leaf(p);
    char line[256];
    std::snprintf(line, sizeof(line), "%d,%s,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.8f\n", p,
                  h.mesh().materials[node.material].name.c_str(), node.centroid.x(), node.centroid.y(),
                  node.centroid.z(), node.normal.x(), node.normal.y(), node.normal.z(), node.area_m2);
    out << line;
  }
}

// Stage radiosity-geometry: the patches, and per pixel its patch and surface point.
Geometry RunGeometryStage(PipelineRun& run, const RadiosityInputs& in) {
  Geometry geo;
  geo.scene = RadiositySceneFromModel(in.model, in.knobs.material_groups);
  radiosity::HierarchyOptions hopt;
  hopt.max_patch_edge_m = in.knobs.patch_edge_m;
  geo.hierarchy = std::make_unique<radiosity::PatchHierarchy>(geo.scene.mesh, hopt);
  geo.caster = std::make_unique<RayCaster>(geo.scene.mesh.geometry);
  const radiosity::PatchHierarchy& h = *geo.hierarchy;
  geo.key.Add("stage", "radiosity-geometry-v4").Add("scene_model", run.scene_model_json()).Add("device", in.device);
  AddKnobsToKey(geo.key, in.knobs, "geometry");
  const StageStore::Result stage = run.RunStage("radiosity-geometry", geo.key, [&](const fs::path& dir) {
    cv::Mat points_m;
    WritePixelMap(dir / "patch_ids.bin", PatchIdImage(h, *geo.caster, in.camera, &points_m));
    WritePixelMap(dir / "pixel_points_m.bin", points_m);
    WritePatchesCsv(dir / "patches.csv", h);
  });
  geo.ids = ReadPixelMap(stage.dir / "patch_ids.bin", CV_32SC1, "patch id map");
  geo.points_m = ReadPixelMap(stage.dir / "pixel_points_m.bin", CV_32FC3, "pixel point map");
  if (geo.points_m.size() != geo.ids.size()) {
    throw IoError((stage.dir / "pixel_points_m.bin").string(), "size differs from the patch ids (rerun with --force)");
  }
  return geo;
}

// The observe stages' results: per bracket its radiance, its observation (the mean radiance per
// patch; absolute once the scale stage has run) and the observe stage's key.
struct Observations {
  std::vector<BracketRadiance> radiance;
  std::vector<radiosity::RadianceObservation> patches;
  std::vector<StageKey> keys;
  std::vector<bool> seen;  // per patch: observed in any bracket
};

// Stage radiosity-observe for one bracket: the mean radiance of each patch the camera saw with at
// least min_patch_pixels good pixels (NaN elsewhere), and the bracket's lamps.
radiosity::RadianceObservation ObserveBracket(PipelineRun& run, const RadiosityInputs& in, const Geometry& geo,
                                              const BracketRadiance& r, StageKey* key) {
  const int n = geo.hierarchy->LeafCount();
  key->Add("stage", "radiosity-observe-v2").AddKey("radiance", r.key).AddKey("geometry", geo.key);
  AddKnobsToKey(*key, in.knobs, "observe");
  const StageStore::Result stage = run.RunStage("radiosity-observe", *key, [&](const fs::path& dir) {
    std::vector<Rgb> sum(n, Rgb::Zero());
    std::vector<int> count(n, 0);
    for (int y = 0; y < geo.ids.rows; ++y) {
      const int* id = geo.ids.ptr<int>(y);
      const auto* px = r.radiance.pixels.ptr<cv::Vec3f>(y);
      const std::uint8_t* status = r.status.empty() ? nullptr : r.status.ptr<std::uint8_t>(y);
      for (int x = 0; x < geo.ids.cols; ++x) {
        if (id[x] < 0 || (status && status[x] != 0)) continue;
        const Rgb v(px[x][0], px[x][1], px[x][2]);
        if (!v.allFinite()) continue;
        sum[id[x]] += v;
        ++count[id[x]];
      }
    }
    std::vector<Rgb> mean(n, Rgb::Constant(std::numeric_limits<double>::quiet_NaN()));
    for (int p = 0; p < n; ++p) {
      if (count[p] >= in.knobs.min_patch_pixels) mean[p] = sum[p] / count[p];
    }
    WritePatchRgb(dir / "observation.csv", "radiance", mean, &count);
  });
  radiosity::RadianceObservation obs;
  obs.radiance = ReadPatchRgb(stage.dir / "observation.csv", n);
  if (in.knobs.direct_at_pixels) obs.pixel_points = PixelPointsPerPatch(geo, r, obs.radiance);
  obs.lighting = LightingAt(in.model, r.utc);
  obs.camera_position_m = in.camera.world_from_camera.translation();
  return obs;
}

// Per bracket: its linear radiance (or the world's, input=truth), then its radiosity-observe stage.
Observations ObserveBrackets(PipelineRun& run, const RadiosityInputs& in, const Geometry& geo) {
  const int n = geo.hierarchy->LeafCount();
  Observations out;
  out.seen = std::vector<bool>(n, false);
  for (const auto& bracket : in.brackets) {
    if (in.knobs.input == "truth") {
      out.radiance.push_back(TruthRadiance(run, bracket, in.camera));
    } else {
      out.radiance.push_back(LinearRadiance(run, bracket));
    }
    const BracketRadiance& r = out.radiance.back();
    if (r.radiance.width() != geo.ids.cols || r.radiance.height() != geo.ids.rows) {
      throw InvalidArgumentError("bracket image " + std::to_string(r.radiance.width()) + "x" +
                                 std::to_string(r.radiance.height()) + " does not match the camera of " + in.device);
    }
    StageKey key;
    radiosity::RadianceObservation obs = ObserveBracket(run, in, geo, r, &key);
    for (int p = 0; p < n; ++p) out.seen[p] = out.seen[p] || obs.radiance[p].allFinite();
    out.patches.push_back(std::move(obs));
    out.keys.push_back(key);
  }
  return out;
}

// The radiosity-scale stage's result: bracket 0's absolute scale and its record.
struct AbsoluteScale {
  StageKey key;
  double k = 1.0;
  RadiosityScaleRecord record;
};

// Bracket 0's absolute scale against the world's rendered radiance, into `j`: the median of
// truth / measured over well-exposed pixels and channels (robust to the few very bright pixels, a
// lamp's hot spot, that dominate a least-squares scale), and the ratio's relative spread.
void AddScaleFromTruth(const RadiosityInputs& in, const BracketRadiance& r, RadiosityScaleRecord* j) {
  const GroundTruth truth = in.world->Render(in.camera, r.utc);
  std::vector<double> ratios;
  for (int y = 0; y < r.radiance.height(); ++y) {
    for (int x = 0; x < r.radiance.width(); ++x) {
      if (!r.status.empty() && r.status.at<std::uint8_t>(y, x) != 0) continue;
      const cv::Vec3f m = r.radiance.pixels.at<cv::Vec3f>(y, x), t = truth.radiance.pixels.at<cv::Vec3f>(y, x);
      for (int c = 0; c < 3; ++c) {
        if (std::isfinite(m[c]) && std::isfinite(t[c]) && m[c] > 0.0f && t[c] > 0.0f) ratios.push_back(t[c] / m[c]);
      }
    }
  }
  if (ratios.empty()) {
    throw InvalidArgumentError("cannot fix the absolute scale: bracket 0 has no well-exposed pixel on a surface");
  }
  const auto mid = ratios.begin() + static_cast<std::ptrdiff_t>(ratios.size() / 2);
  std::nth_element(ratios.begin(), mid, ratios.end());
  const double k = *mid;
  // Spread of the ratio (robust): half the 16th-84th percentile range, relative.
  const auto lo = ratios.begin() + static_cast<std::ptrdiff_t>(ratios.size() * 16 / 100);
  std::nth_element(ratios.begin(), lo, ratios.end());
  const double p16 = *lo;
  const auto hi = ratios.begin() + static_cast<std::ptrdiff_t>(ratios.size() * 84 / 100);
  std::nth_element(ratios.begin(), hi, ratios.end());
  j->scale = k;
  j->samples = static_cast<std::int64_t>(ratios.size());
  j->relative_spread = 0.5 * (*hi - p16) / k;
}

// The reference patches of scale=chart: leaves of a material with known albedo (a chart's
// patches), measured on bracket 0's good pixels whose 3 x 3 neighbourhood lies on the same
// material (a pixel straddling a patch edge mixes two reflectances); at least `min_pixels` each.
std::vector<radiosity::ReferencePatch> ChartReferences(const Geometry& geo, const BracketRadiance& r, int min_pixels) {
  const radiosity::PatchHierarchy& h = *geo.hierarchy;
  auto material_at = [&](int y, int x) {
    if (y < 0 || x < 0 || y >= geo.ids.rows || x >= geo.ids.cols) return -1;
    const int p = geo.ids.at<int>(y, x);
    return p < 0 ? -1 : h.leaf(p).material;
  };
  std::vector<radiosity::ReferencePatch> per_leaf(static_cast<std::size_t>(h.LeafCount()));
  std::vector<int> count(per_leaf.size(), 0);
  for (int y = 0; y < geo.ids.rows; ++y) {
    for (int x = 0; x < geo.ids.cols; ++x) {
      const int p = geo.ids.at<int>(y, x);
      if (p < 0) continue;
      const int material = h.leaf(p).material;
      if (!geo.scene.known_albedo[material]) continue;
      if (!r.status.empty() && r.status.at<std::uint8_t>(y, x) != 0) continue;
      bool inside = true;
      for (int dy = -1; dy <= 1 && inside; ++dy) {
        for (int dx = -1; dx <= 1 && inside; ++dx) inside = material_at(y + dy, x + dx) == material;
      }
      const cv::Vec3f v = r.radiance.pixels.at<cv::Vec3f>(y, x);
      const cv::Vec3f xyz = geo.points_m.at<cv::Vec3f>(y, x);
      if (!inside || !std::isfinite(v[0] + v[1] + v[2]) || !std::isfinite(xyz[0] + xyz[1] + xyz[2])) continue;
      radiosity::ReferencePatch& ref = per_leaf[static_cast<std::size_t>(p)];
      ref.patch = p;
      ref.albedo = *geo.scene.known_albedo[material];
      ref.radiance += Rgb(v[0], v[1], v[2]);
      ref.points.emplace_back(xyz[0], xyz[1], xyz[2]);
      ++count[static_cast<std::size_t>(p)];
    }
  }
  std::vector<radiosity::ReferencePatch> out;
  for (std::size_t p = 0; p < per_leaf.size(); ++p) {
    if (count[p] < min_pixels) continue;
    per_leaf[p].radiance /= count[p];
    out.push_back(std::move(per_leaf[p]));
  }
  return out;
}

bool HasKnownAlbedo(const Geometry& geo) {
  return std::any_of(geo.scene.known_albedo.begin(), geo.scene.known_albedo.end(),
                     [](const auto& a) { return a.has_value(); });
}

// scale=chart's work: the fixed point of the reference patches' scale (reference_scale.h), into `j`.
void AddScaleFromChart(const RadiosityInputs& in, const Geometry& geo, const Observations& observed,
                       const std::vector<radiosity::ReferencePatch>& references, RadiosityScaleRecord* j) {
  const radiosity::ReferenceScaleResult r =
      radiosity::EstimateReferenceScale(*geo.hierarchy, *geo.caster, observed.patches, references,
                                        ReflectanceOptionsFrom(in.knobs, false), radiosity::ReferenceScaleOptions());
  j->scale = r.scale;
  j->direct_only_scale = r.direct_only_scale;
  j->relative_spread = r.relative_spread;
  j->samples = r.samples;
  j->reference_patches = r.patches;
  j->indirect_share = r.indirect_share;
  j->history = r.history;
  j->solves = r.solves;
  j->converged = r.converged;
  j->reason = r.reason;
  j->seconds = r.time_s;
}

// The scale mode a run uses: auto becomes chart when the scene model has materials of known
// albedo and bracket 0 sees them, else none (said in a decision). chart without references throws.
std::string ResolveScaleMode(PipelineRun& run, const RadiosityInputs& in, const Geometry& geo,
                             const std::vector<radiosity::ReferencePatch>& references) {
  const std::string& mode = in.knobs.scale;
  if (mode != "auto" && mode != "chart") return mode;
  if (!references.empty()) return "chart";
  const std::string why = !HasKnownAlbedo(geo)
                              ? "the session's scene model has no material of known albedo (a chart's patches)"
                              : "the first bracket sees no patch of known albedo with at least " +
                                    std::to_string(kMinReferencePixels) + " pixels clear of its edges";
  if (mode == "chart") {
    throw InvalidArgumentError("--set scale=chart: " + why +
                               "; put a ColorChecker in view of the first bracket and give its patches' albedo (the "
                               "scene file's known_albedo, docs/real-data.md), or use scale=none");
  }
  run.Decide("radiosity-scale", "warn",
             why +
                 ": albedo stays relative (bracket 0's units). For absolute albedo put a ColorChecker in view "
                 "(docs/radiosity.md)");
  return "none";
}

// Stage radiosity-scale: an EV-only camera's radiance is relative (and differs per bracket, which
// the reflectance fit corrects against bracket 0). Bracket 0's absolute scale comes from a
// chart's patches of known albedo (scale=chart), from the simulated world's rendered radiance
// (scale=truth, an oracle for evaluation), or stays 1 (none).
AbsoluteScale RunScaleStage(PipelineRun& run, const RadiosityInputs& in, const Geometry& geo,
                            const Observations& observed) {
  const Knobs& knobs = in.knobs;
  const BracketRadiance& bracket0 = observed.radiance.front();
  const std::vector<radiosity::ReferencePatch> references = knobs.input == "truth"
                                                                ? std::vector<radiosity::ReferencePatch>()
                                                                : ChartReferences(geo, bracket0, kMinReferencePixels);
  const std::string mode = knobs.input == "truth" ? "input=truth" : ResolveScaleMode(run, in, geo, references);
  AbsoluteScale out;
  out.key.Add("stage", "radiosity-scale-v4").AddKey("radiance", bracket0.key).Add("mode", mode);
  AddKnobsToKey(out.key, knobs, "scale");
  if (knobs.input == "truth" || mode == "truth") {
    out.key.Add("truth", run.truth()->Key());
  }
  if (mode == "chart") {
    out.key.AddKey("geometry", geo.key);
    for (const StageKey& k : observed.keys) out.key.AddKey("observe", k);
    AddKnobsToKey(out.key, knobs, "reflectance");
  }
  const StageStore::Result stage = run.RunStage("radiosity-scale", out.key, [&](const fs::path& dir) {
    RadiosityScaleRecord j;
    j.mode = mode;
    if (mode == "input=truth") {
      j.mode = "input=truth: already absolute";
    } else if (mode == "truth") {
      AddScaleFromTruth(in, bracket0, &j);
    } else if (mode == "chart") {
      AddScaleFromChart(in, geo, observed, references, &j);
      if (in.world != nullptr && knobs.compare_truth) {  // evaluation only: the oracle's scale beside it
        RadiosityScaleRecord truth;
        AddScaleFromTruth(in, bracket0, &truth);
        j.truth_scale = truth.scale;
        j.error_against_truth = j.scale / truth.scale - 1.0;
      }
    }
    WriteRecord(dir / "scale.json", j);
  });
  out.record = ReadRecord<RadiosityScaleRecord>(stage.dir / "scale.json");
  const RadiosityScaleRecord& scale = out.record;
  out.k = scale.scale;
  std::string text;
  if (knobs.input == "truth") {
    text = "input=truth: the world's radiance is absolute (W m^-2 sr^-1); no camera";
  } else if (mode == "truth") {
    text =
        "bracket 0's absolute scale from the simulated world's radiance (an evaluation oracle; the EV-only "
        "camera gives relative radiance only)";
  } else if (mode == "chart") {
    char buffer[320];
    std::snprintf(buffer, sizeof(buffer),
                  "bracket 0's absolute scale from %d chart patch(es) of known albedo: %.5g (direct light alone "
                  "%.5g; indirect %.0f %% of their light; per-patch spread %.1f %%; %s)",
                  scale.reference_patches.value_or(0), out.k, scale.direct_only_scale.value_or(0.0),
                  100.0 * scale.indirect_share.value_or(0.0), 100.0 * scale.relative_spread.value_or(0.0),
                  scale.converged.value_or(false) ? "converged" : "NOT converged");
    text = buffer;
  } else {
    text = "scale=none: albedo is relative (bracket 0's units), not absolute";
  }
  run.Decide("radiosity-scale", mode == "chart" && !scale.converged.value_or(false) ? "warn" : "choose", text);
  return out;
}

// Loscos's first estimate from bracket 0: direct light plus one ambient term (the mean observed
// radiosity); patches bracket 0 did not observe take the observed patches' mean.
std::vector<Rgb> FirstAlbedoEstimate(const radiosity::PatchHierarchy& h, const radiosity::RadianceObservation& obs,
                                     const radiosity::DirectLight& direct) {
  const int n = h.LeafCount();
  std::vector<Rgb> albedo0(n, Rgb::Constant(0.5));
  Rgb ambient = Rgb::Zero();
  double area = 0.0;
  for (int p = 0; p < n; ++p) {
    if (!obs.radiance[p].allFinite()) continue;
    ambient += h.leaf(p).area_m2 * std::numbers::pi * obs.radiance[p];
    area += h.leaf(p).area_m2;
  }
  if (area > 0.0) ambient /= area;
  Rgb sum = Rgb::Zero();
  int count = 0;
  for (int p = 0; p < n; ++p) {
    const Rgb& l = obs.radiance[p];
    const Rgb e = direct.irradiance[p] + ambient;
    if (!l.allFinite() || !(e.minCoeff() > 0.0)) continue;
    albedo0[p] = (std::numbers::pi * l).cwiseQuotient(e).cwiseMin(1.0).cwiseMax(0.0);
    sum += albedo0[p];
    ++count;
  }
  if (count > 0) {
    for (int p = 0; p < n; ++p) {
      if (!obs.radiance[p].allFinite()) albedo0[p] = sum / count;
    }
  }
  return albedo0;
}

// The planner: the indirect share, from a direct-only albedo of bracket 0 and triangle-level form
// factors. Below the tolerance the radiosity iterations cannot change the albedo by more, and
// they are skipped (returns true).
bool DecideSkipRadiosity(PipelineRun& run, const Knobs& knobs, const Geometry& geo,
                         const radiosity::RadianceObservation& bracket0, IndirectShareFigures* figures) {
  const radiosity::PatchHierarchy& h = *geo.hierarchy;
  const radiosity::DirectLight direct0 =
      radiosity::ComputeDirectLight(h, *geo.caster, bracket0.lighting, ReflectanceOptionsFrom(knobs, false).direct);
  const std::vector<Rgb> albedo0 = FirstAlbedoEstimate(h, bracket0, direct0);
  const radiosity::IndirectShareEstimate share = radiosity::EstimateIndirectShare(
      h, *geo.caster, albedo0, direct0.irradiance, knobs.tolerance, knobs.form_factor_rays);
  const bool skip = share.indirect_share < knobs.tolerance;
  *figures = {share.indirect_share, share.first_bounce_ratio, share.series_ratio, share.mean_enclosure,
              knobs.tolerance};
  run.Decide("radiosity", skip ? "skip" : "run",
             "estimated indirect light " + PercentText(share.indirect_share) + " of the direct (first bounce " +
                 PercentText(share.first_bounce_ratio) + ", enclosure " + std::to_string(share.mean_enclosure) + ") " +
                 (skip ? "is below" : "exceeds") + " the tolerance " + PercentText(knobs.tolerance) +
                 (skip ? ": albedo from direct light only" : ": reflectance iterated with radiosity"));
  return skip;
}

// albedo.csv: per patch its object, whether seen and estimated, its confidence, its albedo and
// iteration 0's.
void WriteAlbedoCsv(const fs::path& path, const radiosity::PatchHierarchy& h,
                    const radiosity::ReflectanceResult& result, const std::vector<bool>& seen) {
  std::ofstream out(path);
  out << "patch,object,seen,estimated,confidence,albedo_r,albedo_g,albedo_b,initial_r,initial_g,initial_b\n";
  for (int p = 0; p < h.LeafCount(); ++p) {
    char line[256];
    const Rgb& a = result.albedo[p];
    const Rgb& i = result.initial_albedo[p];
    std::snprintf(line, sizeof(line), "%d,%s,%d,%d,%.6g,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f\n", p,
                  h.mesh().materials[h.leaf(p).material].name.c_str(), seen[p] ? 1 : 0, result.estimated[p] ? 1 : 0,
                  result.confidence[p], a.x(), a.y(), a.z(), i.x(), i.y(), i.z());
    out << line;
  }
}

// The converged solution under bracket 0's lamps, as radiosity.csv and rendered from the camera
// (radiosity.exr/.png); returns its relative RMS against bracket 0's photograph per observed patch.
double WriteBracket0Solution(const fs::path& dir, const Geometry& geo, const radiosity::RadiositySolution& solution,
                             const radiosity::RadianceObservation& bracket0) {
  const int n = geo.hierarchy->LeafCount();
  WritePatchRgb(dir / "radiosity.csv", "radiosity_w_m2", solution.radiosity);
  std::vector<Rgb> radiance_patch(n);
  for (int p = 0; p < n; ++p) radiance_patch[p] = solution.radiosity[p] / std::numbers::pi;
  RadianceImage rendering = PaintPatches(geo.ids, radiance_patch);
  rendering.unit = RadianceUnit::kWattsPerSqmPerSr;
  calibration::SaveRadianceExr(rendering, (dir / "radiosity.exr").string());
  calibration::SaveImage(RadiancePreview(rendering), (dir / "radiosity.png").string());
  double num = 0.0, den = 0.0;
  for (int p = 0; p < n; ++p) {
    const Rgb& l = bracket0.radiance[p];
    if (!l.allFinite()) continue;
    num += (radiance_patch[p] - l).squaredNorm();
    den += l.squaredNorm();
  }
  return den > 0.0 ? std::sqrt(num / den) : 0.0;
}

// Mean and standard deviation of (model / photograph - 1) over patches and channels.
class RelativeDifference {
 public:
  void Add(const Rgb& ratio) {
    for (int c = 0; c < 3; ++c) {
      sum_ += ratio[c] - 1.0;
      sum2_ += (ratio[c] - 1.0) * (ratio[c] - 1.0);
    }
    count_ += 3;
  }
  RelativeDifferenceFigures Figures() const {
    const double mean = count_ > 0 ? sum_ / count_ : 0.0;
    return {mean, count_ > 0 ? std::sqrt(std::max(0.0, sum2_ / count_ - mean * mean)) : 0.0, count_};
  }

 private:
  double sum_ = 0.0, sum2_ = 0.0;
  int count_ = 0;
};

// The model's own floor: the radiosity solution with the TRUE albedo against bracket 0's
// photograph, per observed patch. What remains here (Monte Carlo noise and bounce truncation of
// the simulated photographs, patch discretisation, camera) no albedo can remove. `solver` is the
// reflectance stage's (its links refined by the converged solution).
ModelGapFigures ModelGap(const Geometry& geo, const MaterialGroups& groups, radiosity::RadiositySolver& solver,
                         const radiosity::DirectLight& direct, const radiosity::RadianceObservation& bracket0,
                         const radiosity::DirectLightOptions& direct_options) {
  const radiosity::PatchHierarchy& h = *geo.hierarchy;
  const int n = h.LeafCount();
  std::vector<Rgb> truth_albedo(n, Rgb::Constant(0.5));
  for (int p = 0; p < n; ++p) truth_albedo[p] = groups.truth[groups.group_of_patch[p]];
  radiosity::RadiositySolution truth_solution;
  solver.Solve(truth_albedo, direct.irradiance, h.LeafEmission(), &truth_solution);
  RelativeDifference per_patch;
  for (int p = 0; p < n; ++p) {
    const Rgb& l = bracket0.radiance[p];
    if (!l.allFinite() || !(l.minCoeff() > 0.0)) continue;
    per_patch.Add((truth_solution.radiosity[p] / std::numbers::pi).cwiseQuotient(l));
  }
  ModelGapFigures model_gap;
  model_gap.per_patch = per_patch.Figures();
  // The same with the direct light averaged over the pixels' own points (what the estimate
  // divides by when direct_at_pixels is on): what is left is the indirect light's error
  // (patch-constant, Monte Carlo noise of the photographs).
  if (!bracket0.pixel_points.empty()) {
    const radiosity::DirectLightAtPoints at =
        radiosity::ComputeDirectLightAtPoints(h, *geo.caster, bracket0.lighting, bracket0.pixel_points, direct_options);
    RelativeDifference at_pixels;
    for (int p = 0; p < n; ++p) {
      const Rgb& l = bracket0.radiance[p];
      if (!at.has_points[p] || !l.allFinite() || !(l.minCoeff() > 0.0)) continue;
      const Rgb model =
          truth_albedo[p].cwiseProduct(at.irradiance[p] + truth_solution.indirect_irradiance[p]) / std::numbers::pi;
      at_pixels.Add(model.cwiseQuotient(l));
    }
    model_gap.at_pixels = at_pixels.Figures();
  }
  return model_gap;
}

// convergence.csv and convergence.png: the albedo change per iteration and, with compare_truth,
// the error and the largest spread per material against the truth.
void WriteConvergence(const fs::path& dir, const radiosity::ReflectanceResult& result,
                      const std::vector<ReflectanceIterationFigures>& per_iteration, bool compare_truth) {
  std::vector<double> change{std::numeric_limits<double>::quiet_NaN()}, error, spread;
  for (double c : result.max_change) change.push_back(c);
  {
    std::ofstream out(dir / "convergence.csv");
    out << "iteration,max_albedo_change,mean_albedo_change,mean_abs_error,max_spread_sd\n";
    for (size_t i = 0; i < per_iteration.size(); ++i) {
      const double mc = i == 0 ? std::numeric_limits<double>::quiet_NaN() : result.max_change[i - 1];
      const double mean_c = i == 0 ? std::numeric_limits<double>::quiet_NaN() : result.mean_change[i - 1];
      const std::optional<AlbedoErrorFigures>& t = per_iteration[i].truth;
      const double e = t ? t->mean_abs_error : std::numeric_limits<double>::quiet_NaN();
      const double sd = t ? t->max_spread_sd : std::numeric_limits<double>::quiet_NaN();
      error.push_back(e);
      spread.push_back(sd);
      char line[160];
      std::snprintf(line, sizeof(line), "%zu,%.6g,%.6g,%.6g,%.6g\n", i, mc, mean_c, e, sd);
      out << line;
    }
  }
  std::vector<std::pair<std::string, std::vector<double>>> series = {{"max albedo change", change}};
  if (compare_truth) {
    series.push_back({"mean |albedo - truth|", error});
    series.push_back({"max spread (sd) per material", spread});
  }
  calibration::SaveImage(LogChart(series, "reflectance iterations (Loscos)"), (dir / "convergence.png").string());
}

// The reflectance result's part of the stage's record.
RadiosityReflectanceRecord ReflectanceRecord(const radiosity::ReflectanceResult& result,
                                             std::vector<ReflectanceIterationFigures> per_iteration) {
  RadiosityReflectanceRecord m;
  m.iterations = result.iterations;
  m.converged = result.converged;
  m.reason = result.reason;
  m.radiosity_skipped = result.radiosity_skipped;
  m.image_scale = result.image_scale;
  m.scale_samples = result.scale_samples;
  m.max_change = result.max_change;
  m.clamped = result.clamped;
  m.seconds = result.time_s;
  m.per_iteration = std::move(per_iteration);
  return m;
}

// The radiosity-reflectance stage's work in `dir`: the reflectance iterations, albedo.csv, the
// reflectance maps, the converged solution, the model's floor, convergence and metrics.json.
void ComputeReflectance(PipelineRun& run, const fs::path& dir, const Knobs& knobs, const Geometry& geo,
                        const MaterialGroups& groups, const Observations& observed, double k_abs, bool skip) {
  const radiosity::PatchHierarchy& h = *geo.hierarchy;
  const radiosity::RadianceObservation& bracket0 = observed.patches.front();
  radiosity::ReflectanceOptions options = ReflectanceOptionsFrom(knobs, skip);
  std::vector<ReflectanceIterationFigures> per_iteration;
  options.on_iteration = [&](int iteration, const std::vector<Rgb>& albedo, const std::vector<double>& scales) {
    ReflectanceIterationFigures& it = per_iteration.emplace_back();
    it.iteration = iteration;
    it.image_scale = scales;
    if (knobs.compare_truth) it.truth = AlbedoErrors(groups, albedo, observed.seen);
    run.Progress("reflectance", iteration, knobs.iterations);
  };
  const radiosity::ReflectanceResult result = radiosity::EstimateReflectance(h, *geo.caster, observed.patches, options);
  if (per_iteration.size() < static_cast<size_t>(knobs.iterations) + 1) std::fprintf(stderr, "\n");

  WriteAlbedoCsv(dir / "albedo.csv", h, result, observed.seen);
  // The reflectance map per pixel (each pixel's own direct light, its patch's indirect).
  const RadianceImage albedo_image =
      PixelReflectance(geo, observed.radiance, observed.patches, result, k_abs, options.direct);
  calibration::SaveRadianceExr(albedo_image, (dir / "reflectance.exr").string());
  calibration::SaveImage(AlbedoPreview(albedo_image), (dir / "reflectance.png").string());
  calibration::SaveImage(AlbedoPreview(PaintPatches(geo.ids, result.albedo)),
                         (dir / "reflectance_patches.png").string());

  // The converged radiosity solution under bracket 0's lamps (absolute units).
  radiosity::RadiositySolver solver(h, *geo.caster, SolverOptionsFrom(knobs));
  const radiosity::DirectLight direct =
      radiosity::ComputeDirectLight(h, *geo.caster, bracket0.lighting, options.direct);
  radiosity::RadiositySolution solution;
  const radiosity::RadiositySummary summary =
      solver.Solve(result.albedo, direct.irradiance, h.LeafEmission(), &solution);
  const double relative_rms = WriteBracket0Solution(dir, geo, solution, bracket0);
  WriteConvergence(dir, result, per_iteration, knobs.compare_truth);

  RadiosityReflectanceRecord m = ReflectanceRecord(result, per_iteration);
  if (knobs.compare_truth && !per_iteration.empty()) {
    m.truth_before = per_iteration.front().truth;
    m.truth_after = per_iteration.back().truth;
    m.truth_pixels = PixelAlbedoErrors(groups, geo.ids, albedo_image);
    m.model_gap_true_albedo_vs_bracket0 = ModelGap(geo, groups, solver, direct, bracket0, options.direct);
  }
  m.solution = {summary.BriefReport(), summary.converged, summary.links, relative_rms};
  WriteRecord(dir / "metrics.json", m);
}

// The radiosity-reflectance stage's result.
struct ReflectanceStage {
  StageKey key;
  fs::path dir;
  RadiosityReflectanceRecord record;
};

// Stage radiosity-reflectance: albedo per patch (iterated with radiosity unless the planner
// skipped it), its decision and outputs.
ReflectanceStage RunReflectanceStage(PipelineRun& run, const RadiosityInputs& in, const Geometry& geo,
                                     const Observations& observed, const AbsoluteScale& scale, bool skip) {
  const MaterialGroups groups = !in.knobs.compare_truth ? MaterialGroups{}
                                : !in.truth_albedo.empty()
                                    ? GroupPatchesFromTruth(*geo.hierarchy, geo.scene, in.model, in.truth_albedo)
                                    : GroupPatches(*geo.hierarchy, geo.scene, in.model, *in.world);
  ReflectanceStage out;
  out.key.Add("stage", "radiosity-reflectance-v4").AddKey("geometry", geo.key).AddKey("scale", scale.key);
  if (!in.knobs.truth_dir.empty()) out.key.AddFileContent("truth_albedo", fs::path(in.knobs.truth_dir) / "albedo.json");
  for (size_t s = 0; s < observed.keys.size(); ++s) {
    out.key.AddKey("observation", observed.keys[s]).Add("utc", FormatIso8601(observed.radiance[s].utc));
  }
  AddKnobsToKey(out.key, in.knobs, "reflectance").Add("skip_radiosity", skip);
  const StageStore::Result stage = run.RunStage("radiosity-reflectance", out.key, [&](const fs::path& dir) {
    ComputeReflectance(run, dir, in.knobs, geo, groups, observed, scale.k, skip);
  });
  out.dir = stage.dir;
  out.record = ReadRecord<RadiosityReflectanceRecord>(out.dir / "metrics.json");
  const RadiosityReflectanceRecord& refl = out.record;
  run.Decide("radiosity-reflectance", refl.converged ? "note" : "warn",
             std::string(refl.converged ? "converged" : "not converged") + " after " + std::to_string(refl.iterations) +
                 " iteration(s): " + refl.reason);
  run.AddOutput(out.dir / "albedo.csv", "albedo per patch (and iteration 0's)");
  run.AddOutput(out.dir / "reflectance.png",
                "reflectance map per pixel (each pixel's own direct light, its patch's indirect light)");
  run.AddOutput(out.dir / "reflectance_patches.png", "albedo per patch, as the radiosity solution uses it");
  run.AddOutput(out.dir / "radiosity.csv", "converged radiosity per patch, bracket 0's lamps, W/m^2");
  run.AddOutput(out.dir / "radiosity.png", "radiosity solution rendered from the camera");
  run.AddOutput(out.dir / "convergence.png", "convergence of the reflectance iterations");
  run.AddOutput(out.dir / "convergence.csv", "albedo change and error per iteration");
  return out;
}

// The albedo columns of the reflectance stage's albedo.csv (n patches).
std::vector<Rgb> ReadAlbedoCsv(const fs::path& path, int n) {
  std::vector<Rgb> albedo;
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    std::string field;
    while (std::getline(ss, field, ',')) f.push_back(field);
    if (f.size() < 8) throw IoError(path.string(), "malformed line '" + line + "'");
    albedo.emplace_back(std::stod(f[5]), std::stod(f[6]), std::stod(f[7]));
  }
  if (static_cast<int>(albedo.size()) != n) throw IoError(path.string(), "patch count differs; rerun with --force");
  return albedo;
}

// The relighting truth: the simulated world rendered with the relighting lamp, or an external
// truth's relit.exr when its relit.json names the same lamp (nullopt, with `why`, otherwise).
std::optional<RadianceImage> RelitTruth(const RadiosityInputs& in, UtcTime utc, std::string* why) {
  if (in.knobs.truth_dir.empty()) {
    return in.world->RenderWithPointLamp(in.camera, utc, in.knobs.light_m,
                                         Eigen::Vector3d::Constant(in.knobs.light_intensity_w_sr));
  }
  const fs::path dir(in.knobs.truth_dir);
  if (!fs::exists(dir / "relit.exr") || !fs::exists(dir / "relit.json")) {
    *why = "the external truth has no relit.exr + relit.json";
    return std::nullopt;
  }
  const nlohmann::json lamp = ReadJsonFile(
      dir / "relit.json", "--set truth_dir needs relit.json with the lamp of relit.exr: docs/radiosity.md");
  const Eigen::Vector3d at(lamp.at("light_m").at(0).get<double>(), lamp.at("light_m").at(1).get<double>(),
                           lamp.at("light_m").at(2).get<double>());
  const double intensity = lamp.at("light_intensity_w_sr").get<double>();
  if ((at - in.knobs.light_m).norm() > 1e-6 || std::abs(intensity - in.knobs.light_intensity_w_sr) > 1e-6) {
    *why =
        "the external truth's relit.exr has its lamp elsewhere (relit.json): set light_x/y/z and light_intensity "
        "to its values to compare";
    return std::nullopt;
  }
  RadianceImage image = calibration::LoadRadianceExr((dir / "relit.exr").string());
  if (image.width() != in.camera.intrinsics.width || image.height() != in.camera.intrinsics.height) {
    throw InvalidArgumentError((dir / "relit.exr").string() + " does not have the camera's size");
  }
  return image;
}

// The relit rendering against the same lamp in the truth (RelitTruth: the simulated
// world's renderer with its interreflection settings, or an external render) at bracket 0's time, into `m`; writes
// relit_truth.png. Per patch (the means of the relit and the truth's pixels on it): pixels carry the renderer's Monte
// Carlo noise, patches average it. Per pixel as well.
void CompareRelitWithTruth(const RadiosityInputs& in, const Geometry& geo, const RadianceImage& relit, UtcTime utc,
                           const fs::path& dir, RadiosityRelightRecord* m) {
  const int n = geo.hierarchy->LeafCount();
  std::string why;
  const std::optional<RadianceImage> truth_image = RelitTruth(in, utc, &why);
  if (!truth_image) {
    m->truth_not_compared = why;
    return;
  }
  const RadianceImage& truth = *truth_image;
  std::vector<Rgb> sum(n, Rgb::Zero()), relit_sum(n, Rgb::Zero());
  std::vector<int> count(n, 0);
  double pixel_num = 0.0, pixel_den = 0.0;
  for (int y = 0; y < geo.ids.rows; ++y) {
    for (int x = 0; x < geo.ids.cols; ++x) {
      const int id = geo.ids.at<int>(y, x);
      const cv::Vec3f t = truth.pixels.at<cv::Vec3f>(y, x);
      const cv::Vec3f r = relit.pixels.at<cv::Vec3f>(y, x);
      if (id < 0 || !std::isfinite(t[0]) || !std::isfinite(r[0])) continue;
      sum[id] += Rgb(t[0], t[1], t[2]);
      relit_sum[id] += Rgb(r[0], r[1], r[2]);
      ++count[id];
      pixel_num += (Rgb(r[0], r[1], r[2]) - Rgb(t[0], t[1], t[2])).squaredNorm();
      pixel_den += Rgb(t[0], t[1], t[2]).squaredNorm();
    }
  }
  double num = 0.0, den = 0.0, model = 0.0, truth_total = 0.0;
  int patches = 0;
  for (int p = 0; p < n; ++p) {
    if (count[p] < in.knobs.min_patch_pixels) continue;
    const Rgb t = sum[p] / count[p];
    const Rgb l = relit_sum[p] / count[p];
    num += (l - t).squaredNorm();
    den += t.squaredNorm();
    model += l.sum();
    truth_total += t.sum();
    ++patches;
  }
  m->truth_relative_rms_per_patch = den > 0.0 ? std::sqrt(num / den) : 0.0;
  m->truth_relative_rms_per_pixel = pixel_den > 0.0 ? std::sqrt(pixel_num / pixel_den) : 0.0;
  m->truth_mean_ratio = truth_total > 0.0 ? model / truth_total : 0.0;
  m->truth_patches = patches;
  calibration::SaveImage(RadiancePreview(truth), (dir / "relit_truth.png").string());
}

// Stage radiosity-relight: every recorded lamp off, one point lamp where the command line puts
// it; the radiosity solution with the estimated albedo, rendered per pixel.
RadiosityRelightRecord RunRelightStage(PipelineRun& run, const RadiosityInputs& in, const Geometry& geo,
                                       const ReflectanceStage& refl, bool skip, UtcTime bracket0_utc) {
  const Knobs& knobs = in.knobs;
  const radiosity::PatchHierarchy& h = *geo.hierarchy;
  StageKey relight_key;
  relight_key.Add("stage", "radiosity-relight-v4").AddKey("reflectance", refl.key);
  AddKnobsToKey(relight_key, knobs, "relight");
  if (!knobs.truth_dir.empty()) {
    for (const char* name : {"relit.exr", "relit.json"}) {
      const fs::path path = fs::path(knobs.truth_dir) / name;
      if (fs::exists(path)) relight_key.AddFileContent(name, path);
    }
  }
  const StageStore::Result stage = run.RunStage("radiosity-relight", relight_key, [&](const fs::path& dir) {
    const std::vector<Rgb> albedo = ReadAlbedoCsv(refl.dir / "albedo.csv", h.LeafCount());
    radiosity::Lighting lighting;
    lighting.point_lights.push_back({knobs.light_m, Rgb::Constant(knobs.light_intensity_w_sr)});
    radiosity::RoomRelightOptions options;
    options.direct = ReflectanceOptionsFrom(knobs, skip).direct;
    options.radiosity = SolverOptionsFrom(knobs);
    const radiosity::RoomRelightResult r =
        radiosity::RelightRoom(h, *geo.caster, albedo, lighting, {geo.ids, geo.points_m}, options);
    calibration::SaveRadianceExr(r.relit, (dir / "relit.exr").string());
    calibration::SaveImage(RadiancePreview(r.relit), (dir / "relit.png").string());
    WritePatchRgb(dir / "relit_radiosity.csv", "radiosity_w_m2", r.radiosity);
    RadiosityRelightRecord m;
    m.light_m = knobs.light_m;
    m.light_intensity_w_sr = knobs.light_intensity_w_sr;
    m.solution = r.solution.BriefReport();
    if (knobs.compare_truth) CompareRelitWithTruth(in, geo, r.relit, bracket0_utc, dir, &m);
    WriteRecord(dir / "metrics.json", m);
  });
  run.AddOutput(stage.dir / "relit.png", "relit rendering under the new lamp");
  run.AddOutput(stage.dir / "relit.exr", "relit radiance, W m^-2 sr^-1");
  return ReadRecord<RadiosityRelightRecord>(stage.dir / "metrics.json");
}

}  // namespace

RadiosityPipelineSummary RunRadiosityPipeline(PipelineRun& run) {
  RadiosityPipelineSummary summary;
  const RadiosityInputs in = ReadRadiosityInputs(run);
  const Knobs& knobs = in.knobs;
  run.Decide("radiosity", "plan",
             std::to_string(in.brackets.size()) + " bracket(s) of " + in.device +
                 "; patches <= " + std::to_string(knobs.patch_edge_m) + " m, " + std::to_string(knobs.iterations) +
                 " iteration(s) at most, tolerance " + std::to_string(knobs.tolerance));
  if (run.request().explain) {
    run.Decide("radiosity", "note", "the indirect-share test (skip or run radiosity) needs the radiance: not run here");
    return summary;
  }
  if (in.world != nullptr && in.world->IndirectBounces() == 0) {
    run.Decide("radiosity", "note",
               "the session's world rendered direct light only (render.indirect_bounces 0): its photographs have no "
               "interreflection, so albedo from a radiosity model is biased low; compare with the skipped result");
  }
  const Geometry geo = RunGeometryStage(run, in);
  summary.patches = geo.hierarchy->LeafCount();
  summary.mesh_triangles = geo.hierarchy->mesh().TriangleCount();
  Observations observed = ObserveBrackets(run, in, geo);
  summary.patches_seen = std::count(observed.seen.begin(), observed.seen.end(), true);
  const AbsoluteScale scale = RunScaleStage(run, in, geo, observed);
  summary.absolute_scale = scale.record;
  for (auto& obs : observed.patches) {
    for (Rgb& v : obs.radiance) v *= scale.k;
  }
  summary.indirect_share.emplace();
  const bool skip = DecideSkipRadiosity(run, knobs, geo, observed.patches.front(), &*summary.indirect_share);
  const ReflectanceStage reflectance = RunReflectanceStage(run, in, geo, observed, scale, skip);
  summary.reflectance = reflectance.record;
  summary.relight = RunRelightStage(run, in, geo, reflectance, skip, observed.radiance.front().utc);
  return summary;
}

namespace {

std::string RadiosityHeadline(const RadiosityPipelineSummary& s) {
  if (!s.reflectance) return "";
  const RadiosityReflectanceRecord& r = *s.reflectance;
  std::string text = std::to_string(s.patches.value_or(0)) + " patches, " +
                     (r.converged ? "converged" : "NOT converged") + " after " + std::to_string(r.iterations) +
                     " iteration(s)";
  if (r.truth_after && !r.truth_after->materials.empty()) {
    double sum = 0.0, worst = 0.0;
    for (const MaterialAlbedoError& m : r.truth_after->materials) {
      sum += m.error_of_mean;
      worst = std::max(worst, m.error_of_mean);
    }
    const int n = static_cast<int>(r.truth_after->materials.size());
    char text_buffer[120];
    std::snprintf(text_buffer, sizeof(text_buffer),
                  "; albedo error of the mean per material: mean %.3f, worst %.3f (%d materials)", sum / n, worst, n);
    text += text_buffer;
  }
  return text;
}

std::vector<Figure> RadiosityFigures(const RadiosityPipelineSummary& s) {
  std::vector<Figure> f;
  if (s.patches) AddFigure(f, "patches", static_cast<double>(*s.patches), "", 9);
  if (s.indirect_share) AddFigure(f, "indirect light, estimated share of the direct", s.indirect_share->estimate, "%");
  if (s.reflectance) {
    const RadiosityReflectanceRecord& r = *s.reflectance;
    AddFigure(f, "reflectance iterations", static_cast<double>(r.iterations), "", 4);
    AddYesNoFigure(f, "converged", r.converged);
    if (r.truth_after) {
      for (const MaterialAlbedoError& m : r.truth_after->materials) {
        AddFigure(f, "albedo error of the mean, " + m.material, m.error_of_mean, "(albedo)", 3);
      }
    }
  }
  if (s.relight) {
    AddFigure(f, "relit vs truth, per pixel (relative RMS)", s.relight->truth_relative_rms_per_pixel, "%");
    AddFigure(f, "relit vs truth, per patch", s.relight->truth_relative_rms_per_patch, "%");
  }
  return f;
}

}  // namespace

PipelineEntry RadiosityPipelineEntry() {
  return MakePipelineEntry(TypedPipeline<RadiosityPipelineSummary>{
      "radiosity",
      "per-patch albedo of a room under a moving lamp (Loscos: EV-only HDR, consistency scales, reflectance "
      "iterated with radiosity), radiosity solution, relighting (--set light_x=..,light_y=..,light_z=..)",
      RunRadiosityPipeline,
      WithRadianceKnobs(DescribeKnobs<Knobs>()),
      RadiosityHeadline,
      RadiosityFigures,
      {"radiance", "geometry", "observe", "scale", "reflectance", "relight"}});
}

}  // namespace relume::pipeline
