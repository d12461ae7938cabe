#include "pipeline/irm_pipeline.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <utility>

#include "calibration/image_file.h"
#include "capture/scene_model_record.h"
#include "core/error.h"
#include "core/frames.h"
#include "pipeline/irm_scene.h"
#include "pipeline/radiance.h"
#include "processing/geometry/ray_caster.h"
#include "processing/irm/relight.h"

namespace relume::pipeline {
namespace fs = std::filesystem;

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// ---------------------------------------------------------------------------------------
// Inputs: brackets, cameras, sun, mesh

std::vector<capture::FrameRecord> OneBracket(const PipelineRun& run, const std::optional<std::string>& selector,
                                             const char* role) {
  if (!selector) {
    throw InvalidArgumentError(std::string("the irm pipeline needs --") + role +
                               " FRAME: a still bracket of the session (e.g. --source bracket:1 --target bracket:2; "
                               "`relume session info` lists them); without either, it takes the earliest and the "
                               "latest bracket of a camera with two complete brackets, and this session has none");
  }
  const auto brackets = StillBrackets(run.session(), selector);
  if (brackets.size() != 1) {
    throw InvalidArgumentError(std::string("--") + role + " " + *selector + " selects " +
                               std::to_string(brackets.size()) +
                               " still brackets; the irm pipeline relights one photograph: select one bracket "
                               "(bracket:N) or one frame id");
  }
  return brackets.front();
}

Eigen::Vector3f SunDirection(const BracketRadiance& r, const char* role) {
  if (!(r.sun_elevation_deg > 0.0)) {
    throw InvalidArgumentError(std::string("the ") + role + " photograph was taken with the sun at elevation " +
                               std::to_string(r.sun_elevation_deg) +
                               " deg (below the horizon): IRMs relight sunlit scenes; choose a daytime bracket");
  }
  return EnuDirectionFromAzimuthElevation(DegToRad(r.sun_azimuth_deg), DegToRad(r.sun_elevation_deg)).cast<float>();
}

void AddCamera(StageKey& key, const std::string& name, const PinholeCamera& camera) {
  const PinholeIntrinsics& k = camera.intrinsics;
  key.Add(name + ".size", static_cast<std::int64_t>(k.width) * 100000 + k.height);
  key.Add(name + ".fx", k.fx).Add(name + ".fy", k.fy).Add(name + ".cx", k.cx).Add(name + ".cy", k.cy);
  const Eigen::Matrix4d m = camera.world_from_camera.matrix();
  for (int i = 0; i < 12; ++i) key.Add(name + ".pose", m(i % 3, i / 3));
}

// The pipeline's knobs (knobs.h), with the stages each changes.
struct IrmKnobs {
  irm::RelightOptions relight;
  IrmMeshOptions mesh;
  std::string mesh_frame = "enu";
  int mesh_utm_zone = 0;  // 0: the site's
  bool compare_truth = true;
  // A truth made outside relume (another renderer, a measurement): a folder with target.exr (the
  // scene from the source camera under the target's light, linear), source_sun.exr and
  // target_sun.exr (R: the sun's visible fraction per pixel, NaN where the surface faces away;
  // G: 1 on a surface, 0 for sky) and optionally source.exr (the source photograph's truth: the
  // floor the relit image inherits). See docs/irm.md.
  std::string truth_dir;

  template <typename V>
  void VisitKnobs(V& v) {
    v.Knob("mesh_spacing_m", mesh.spacing_m, "largest edge of the mesh's triangles after splitting (m)", {"mesh"});
    v.Knob("mesh_frame", mesh_frame, "frame of a --mesh file: enu or utm", {"mesh"});
    v.Knob("mesh_utm_zone", mesh_utm_zone, "UTM zone of a --mesh file (0: the site's)", {"mesh"});
    v.Knob("sun_samples", relight.sun_samples, "rays per vertex over the sun's disk", {"view"});
    v.Knob("sky_samples", relight.sky_samples, "cosine-weighted rays per vertex for its sky view (0: open sky)",
           {"view", "build"});
    v.Knob("penumbra", relight.use_penumbra_fractions, "use fractional sun visibility in penumbrae", {"view"});
    v.Knob("sky_gradient", relight.sky_gradient, "measure the sky's brightness against elevation in each photograph",
           {"build"});
    v.Knob("bins", relight.irm.bins, "octahedral normal bins per side of each ratio map", {"build"});
    v.Knob("model_correction", relight.irm.model_correction, "correct the ratios by the sun + sky model's residual",
           {"build"});
    v.Knob("indirect", relight.indirect,
           "gather each surface's light from the other surfaces out of the photographs (interreflection)", {"build"});
    v.Knob("indirect_samples", relight.indirect_samples, "cosine-weighted rays per vertex for the indirect light",
           {"build"});
    v.Knob("indirect_passes", relight.indirect_passes,
           "refinements of the unseen surfaces' radiance for the indirect light (each a gather and a refit)",
           {"build"});
    v.Knob("exact_shadow_edges", relight.exact_shadow_edges,
           "ray-cast the sun fraction of pixels on triangles a shadow edge crosses", {"relight"});
    v.Knob("threads", relight.threads,
           "threads for per-pixel relighting, 0: the CPUs this process may use (no effect on results)", {"none"});
    v.Knob("compare_truth", compare_truth, "compare the relit image with the simulated world's truth", {"report"});
    v.Knob("truth_dir", truth_dir,
           "compare with a truth made outside relume: a folder of target.exr, source_sun.exr, target_sun.exr",
           {"report"});
  }
  bool IsValid(std::string* why) const {
    if (!relight.IsValid(why) || !mesh.IsValid(why)) return false;
    if (mesh_frame != "enu" && mesh_frame != "utm") {
      *why = "mesh_frame=" + mesh_frame + ": expected enu or utm";
      return false;
    }
    if (mesh_utm_zone < 0 || mesh_utm_zone > 60) {
      *why = "mesh_utm_zone must be 1..60 (0: the site's)";
      return false;
    }
    return true;
  }
};

struct SceneGeometry {
  StageKey key;
  std::string origin;
  std::function<TriangleMesh()> make;  // the mesh (split, with normals); run by MeshStage when not cached
};

SceneGeometry LoadGeometry(PipelineRun& run, const IrmKnobs& knobs) {
  const IrmMeshOptions& options = knobs.mesh;
  const std::string& frame_name = knobs.mesh_frame;
  const int zone = knobs.mesh_utm_zone;
  SceneGeometry g;
  g.key.Add("stage", "irm-mesh-v3").Add("sphere_segments", options.sphere_segments);
  AddKnobsToKey(g.key, knobs, "mesh");
  if (run.request().mesh) {
    const fs::path& path = *run.request().mesh;
    if (!fs::exists(path)) throw IoError(path.string(), "does not exist (--mesh takes an OBJ or PLY file)");
    const MeshFrame frame = frame_name == "utm" ? MeshFrame::kUtm : MeshFrame::kEnu;
    const Site site = run.session().info().site;
    const LoadedSceneMesh loaded =
        LoadSceneMesh(path.string(), frame, site, zone > 0 ? std::optional<int>(zone) : std::nullopt, options);
    g.make = [mesh = loaded.mesh] { return mesh; };
    g.key.AddFileContent("mesh", path).Add("frame", frame_name).Add("zone", loaded.utm_zone);
    if (frame == MeshFrame::kUtm) {
      g.key.Add("site.lat", site.latitude_deg()).Add("site.lon", site.longitude_deg()).Add("site.h", site.height_m);
      run.Decide("mesh", "choose",
                 "--mesh " + path.string() + " in UTM zone " + std::to_string(loaded.utm_zone) +
                     ": converted to ENU through geodetic coordinates (meridian convergence " +
                     std::to_string(loaded.convergence_rad * 180.0 / std::numbers::pi) + " deg)");
    } else {
      run.Decide("mesh", "choose", "--mesh " + path.string() + " (ENU at the site)");
    }
    g.origin = path.string();
  } else if (const SceneModel* model = run.scene_model()) {
    if (model->objects.empty()) {
      throw InvalidArgumentError(
          "the irm pipeline needs the scene's geometry, and the session's scene model has no "
          "object; give --mesh FILE (OBJ or PLY, ENU at the site, or UTM with --set "
          "mesh_frame=utm)");
    }
    g.make = [model = *model, options] { return ProcessingMeshFromModel(model, options); };
    // Keyed by the geometry alone: a new camera pose or lamp re-runs the views, not the mesh.
    SceneModel geometry_only = *model;
    geometry_only.cameras.clear();
    geometry_only.lamps.clear();
    g.key.Add("scene_model_geometry", capture::SceneModelToJson(geometry_only));
    run.Decide("mesh", "choose",
               "the session's scene model (" + std::to_string(model->objects.size()) + " objects, " +
                   std::to_string(model->TriangleCount()) + " triangles), split to " +
                   std::to_string(options.spacing_m) + " m");
    g.origin = "session scene model";
  } else {
    throw InvalidArgumentError(
        "the irm pipeline needs the scene's geometry and cameras, and the session has no scene model (`relume "
        "session info`): " +
        SceneModelAdvice(run.session().dir()) +
        "; --mesh FILE (OBJ or PLY, ENU at the site, or UTM with --set mesh_frame=utm) gives the geometry alone");
  }
  return g;
}

// The scene mesh as a stage (mesh.bin: counts, positions, triangles, normals, albedo, parts; mesh.json:
// the counts): a rerun reads it only when a stage that casts rays has to run.
// Stage irm-mesh's record (mesh.json) beside mesh.bin.
struct MeshCounts {
  std::int64_t vertices = 0, triangles = 0;
  template <typename V>
  void VisitFields(V& v) {
    v.Field("vertices", vertices);
    v.Field("triangles", triangles);
  }
};

struct MeshStage {
  std::int64_t vertices = 0;
  std::int64_t triangles = 0;
  Lazy<TriangleMesh> mesh;
};

template <typename T>
void WriteVectors(std::ofstream& out, const std::vector<T>& v) {
  const std::int64_t n = static_cast<std::int64_t>(v.size());
  out.write(reinterpret_cast<const char*>(&n), sizeof(n));
  out.write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(v.size() * sizeof(T)));
}

// Reads a count and that many elements; a count the rest of the file cannot hold (a damaged
// file) fails the stream instead of allocating it.
template <typename T>
void ReadVectors(std::ifstream& in, std::uintmax_t file_bytes, std::vector<T>* v) {
  std::int64_t n = 0;
  in.read(reinterpret_cast<char*>(&n), sizeof(n));
  if (!in || n < 0 || static_cast<std::uintmax_t>(n) > file_bytes / sizeof(T)) {
    in.setstate(std::ios::failbit);
    return;
  }
  v->resize(static_cast<std::size_t>(n));
  in.read(reinterpret_cast<char*>(v->data()), static_cast<std::streamsize>(v->size() * sizeof(T)));
}

TriangleMesh ReadMeshFile(const fs::path& path) {
  std::error_code ec;
  const std::uintmax_t bytes = fs::file_size(path, ec);
  if (ec) throw IoError(path.string(), "cannot be read; run with --force");
  std::ifstream in(path, std::ios::binary);
  TriangleMesh mesh;
  ReadVectors(in, bytes, &mesh.positions);
  ReadVectors(in, bytes, &mesh.triangles);
  ReadVectors(in, bytes, &mesh.normals);
  ReadVectors(in, bytes, &mesh.albedo);
  ReadVectors(in, bytes, &mesh.part);
  std::string why;
  if (!in || !mesh.IsValid(&why)) throw IoError(path.string(), "is short or unreadable; run with --force");
  return mesh;
}

MeshStage RunMeshStage(PipelineRun& run, const SceneGeometry& g) {
  std::shared_ptr<TriangleMesh> made;
  const StageStore::Result stage = run.RunStage("irm-mesh", g.key, [&](const fs::path& dir) {
    made = std::make_shared<TriangleMesh>(g.make());
    if (made->triangles.empty()) throw InvalidArgumentError("the scene geometry (" + g.origin + ") has no triangles");
    std::ofstream out(dir / "mesh.bin", std::ios::binary);
    WriteVectors(out, made->positions);
    WriteVectors(out, made->triangles);
    WriteVectors(out, made->normals);
    WriteVectors(out, made->albedo);
    WriteVectors(out, made->part);
    if (!out) throw IoError((dir / "mesh.bin").string(), "cannot be written");
    WriteRecord(dir / "mesh.json", MeshCounts{static_cast<std::int64_t>(made->vertex_count()),
                                              static_cast<std::int64_t>(made->triangle_count())});
  });
  MeshStage m;
  const auto counts = ReadRecord<MeshCounts>(stage.dir / "mesh.json");
  m.vertices = counts.vertices;
  m.triangles = counts.triangles;
  m.mesh = made ? Lazy<TriangleMesh>([made] { return *made; })
                : Lazy<TriangleMesh>([path = stage.dir / "mesh.bin"] { return ReadMeshFile(path); });
  return m;
}

// The ray caster over the scene mesh, built (and the relighting inputs checked) when a stage
// first needs it: building Embree's tree over the demo's 666k triangles is most of a rerun.
class LazyCaster {
 public:
  LazyCaster(const MeshStage& mesh, const irm::View& source, const irm::View& target,
             const irm::RelightOptions& options)
      : mesh_(mesh), source_(source), target_(target), options_(options) {}
  const RayCaster& get() const {
    if (!caster_) {
      caster_ = std::make_unique<RayCaster>(mesh_.mesh.get());
      irm::CheckRelightInputs(*caster_, source_, target_, options_);
    }
    return *caster_;
  }

 private:
  const MeshStage& mesh_;
  const irm::View& source_;
  const irm::View& target_;
  const irm::RelightOptions& options_;
  mutable std::unique_ptr<RayCaster> caster_;
};

// ---------------------------------------------------------------------------------------
// Stages

irm::SkyShape SkyShapeStage(PipelineRun& run, const std::string& role, const LazyCaster& caster, const irm::View& view,
                            const irm::RelightOptions& options, const StageKey& view_key, const StageKey& radiance_key);

irm::ViewGeometry ViewStage(PipelineRun& run, const std::string& role, const LazyCaster& caster, const MeshStage& mesh,
                            const irm::View& view, const IrmKnobs& knobs, const StageKey& mesh_key,
                            const StageKey& radiance_key, StageKey* key) {
  const irm::RelightOptions& options = knobs.relight;
  key->Add("stage", "irm-view-v5").AddKey("mesh", mesh_key);
  AddCamera(*key, "camera", view.camera);
  for (int k = 0; k < 3; ++k) key->Add("sun", static_cast<double>(view.sun_dir[k]));
  key->Add("sun_radius", static_cast<double>(options.sun_angular_radius_rad));
  key->Add("lit", static_cast<double>(options.irm.lit_threshold));
  AddKnobsToKey(*key, knobs, "view");
  // Sky views are geometry-only and read from the source photograph's stage alone.
  const bool with_sky_view = role == "source" && options.sky_samples > 0;
  key->Add("with_sky_view", with_sky_view);
  irm::ViewGeometry geometry;
  bool computed = false;
  const StageStore::Result stage = run.RunStage("irm-view-" + role, *key, [&](const fs::path& dir) {
    geometry = irm::ComputeViewGeometry(caster.get(), view, options, with_sky_view);
    computed = true;
    std::ofstream out(dir / "vertices.bin", std::ios::binary);
    out.write(reinterpret_cast<const char*>(geometry.visible.data()),
              static_cast<std::streamsize>(geometry.visible.size()));
    out.write(reinterpret_cast<const char*>(geometry.sun_fraction.data()),
              static_cast<std::streamsize>(geometry.sun_fraction.size() * sizeof(float)));
    out.write(reinterpret_cast<const char*>(geometry.sky_view.data()),
              static_cast<std::streamsize>(geometry.sky_view.size() * sizeof(float)));
    out.write(reinterpret_cast<const char*>(geometry.sky_moment.data()),
              static_cast<std::streamsize>(geometry.sky_moment.size() * sizeof(float)));
    if (!out) throw IoError((dir / "vertices.bin").string(), "cannot be written");
    out.close();
    WriteJsonFile(dir / "view.json", {{"vertices", geometry.visible.size()},
                                      {"visible", std::count(geometry.visible.begin(), geometry.visible.end(), 1)},
                                      {"visible_in_cast_shadow", geometry.visible_in_cast_shadow},
                                      {"seconds", geometry.seconds}});
  });
  if (!computed) {
    const std::size_t n = static_cast<std::size_t>(mesh.vertices);
    geometry.visible.resize(n);
    geometry.sun_fraction.resize(n);
    std::ifstream in(stage.dir / "vertices.bin", std::ios::binary);
    in.read(reinterpret_cast<char*>(geometry.visible.data()), static_cast<std::streamsize>(n));
    in.read(reinterpret_cast<char*>(geometry.sun_fraction.data()), static_cast<std::streamsize>(n * sizeof(float)));
    if (with_sky_view) {
      geometry.sky_view.resize(n);
      in.read(reinterpret_cast<char*>(geometry.sky_view.data()), static_cast<std::streamsize>(n * sizeof(float)));
      geometry.sky_moment.resize(n);
      in.read(reinterpret_cast<char*>(geometry.sky_moment.data()), static_cast<std::streamsize>(n * sizeof(float)));
    }
    if (!in) throw IoError((stage.dir / "vertices.bin").string(), "is short or unreadable; run with --force");
    geometry.visible_in_cast_shadow = ReadJsonFile(stage.dir / "view.json")["visible_in_cast_shadow"].get<int>();
  }
  // The sky's shape is the photograph's, not the geometry's: a stage of its own, keyed by the view
  // and the radiance it is measured on.
  if (options.sky_samples > 0 && options.sky_gradient) {
    geometry.sky_shape = SkyShapeStage(run, role, caster, view, options, *key, radiance_key);
    const irm::SkyShape& shape = geometry.sky_shape;
    char text[200];
    if (shape.measured) {
      std::snprintf(text, sizeof(text),
                    "sky brightness against elevation from %d sky pixels (%.0f to %.0f deg): g = %.3f, %.3f, %.3f",
                    shape.pixels, shape.min_elevation_rad * 180.0 / std::numbers::pi,
                    shape.max_elevation_rad * 180.0 / std::numbers::pi, shape.gradient.x(), shape.gradient.y(),
                    shape.gradient.z());
      run.Decide("irm-sky-" + role, "note", text);
    } else {
      run.Decide("irm-sky-" + role, "note", "sky taken as uniform: " + shape.reason);
    }
  }
  return geometry;
}

irm::SkyShape SkyShapeStage(PipelineRun& run, const std::string& role, const LazyCaster& caster, const irm::View& view,
                            const irm::RelightOptions& options, const StageKey& view_key,
                            const StageKey& radiance_key) {
  const irm::SkyShapeOptions& o = options.sky_shape;
  StageKey key;
  key.Add("stage", "irm-sky-v1").AddKey("view", view_key).AddKey("radiance", radiance_key);
  key.Add("max_rays", o.max_rays).Add("sun_exclusion_rad", static_cast<double>(o.sun_exclusion_rad));
  key.Add("min_span_rad", static_cast<double>(o.min_elevation_span_rad)).Add("min_pixels", o.min_pixels);
  key.Add("trim", static_cast<double>(o.trim_fraction)).Add("max_gradient", static_cast<double>(o.max_abs_gradient));
  const StageStore::Result stage = run.RunStage("irm-sky-" + role, key, [&](const fs::path& dir) {
    const irm::SkyShape shape =
        irm::FitSkyShape(caster.get(), view.image->pixels, view.camera, view.mask, view.sun_dir.normalized(), o);
    WriteRecord(dir / "sky.json", shape);
  });
  return ReadRecord<irm::SkyShape>(stage.dir / "sky.json");
}

// One IRM as images: ratios (EXR, 0 where the bin is empty), a preview (PNG) and the sample
// count per bin (16-bit PNG).
void SaveMapImages(const irm::RatioMap& map, const std::string& name, const fs::path& dir) {
  RadianceImage ratio = MakeRadianceImage(map.bins, map.bins);
  cv::Mat count(map.bins, map.bins, CV_16UC1, cv::Scalar(0));
  float largest = 0.0f;
  for (int j = 0; j < map.bins; ++j) {
    for (int i = 0; i < map.bins; ++i) {
      const std::size_t b = static_cast<std::size_t>(j * map.bins + i);
      const Eigen::Vector3f& r = map.ratio[b];
      cv::Vec3f& out = ratio.pixels.at<cv::Vec3f>(j, i);
      for (int c = 0; c < 3; ++c) out[c] = std::isfinite(r[c]) ? r[c] : 0.0f;
      if (r.allFinite()) largest = std::max(largest, r.maxCoeff());
      count.at<std::uint16_t>(j, i) = static_cast<std::uint16_t>(std::min(map.count[b], 65535));
    }
  }
  calibration::SaveRadianceExr(ratio, (dir / (name + ".exr")).string());
  calibration::SaveImage(RadiancePreview(ratio, largest > 0.0f ? largest : 1.0), (dir / (name + ".png")).string());
  calibration::SaveImage(count, (dir / (name + "_count.png")).string());
}

double WhiteOf(const RadianceImage& image) {
  std::vector<float> lum;
  for (int y = 0; y < image.height(); ++y) {
    const auto* p = image.pixels.ptr<cv::Vec3f>(y);
    for (int x = 0; x < image.width(); ++x) {
      const float l = 0.2126f * p[x][0] + 0.7152f * p[x][1] + 0.0722f * p[x][2];
      if (std::isfinite(l)) lum.push_back(l);
    }
  }
  if (lum.empty()) return 1.0;
  const std::size_t k = lum.size() * 99 / 100;
  std::nth_element(lum.begin(), lum.begin() + static_cast<std::ptrdiff_t>(k), lum.end());
  return lum[k] > 0.0f ? lum[k] : 1.0;
}

// The seam: where the source's relit surfaces meet the target photograph. For each relit
// source pixel whose surface the target also sees (unoccluded, inside the image, well
// exposed), the target's radiance there; the overlap's boundary pixels (a 4-neighbour outside
// the overlap, or the image border) form the seam. Differences are relative, per channel,
// against the target.
struct SeamResult {
  double overlap_before = 0.0, overlap_after = 0.0, seam_before = 0.0, seam_after = 0.0;
  std::int64_t overlap_pixels = 0, seam_pixels = 0;
  RadianceImage image;  // channel 0: |difference| before, 1: after, 2: 1 on the seam
};

SeamResult Seam(const RayCaster& caster, const irm::View& source, const irm::View& target,
                const irm::RelightResult& relit) {
  const int w = source.image->width(), h = source.image->height();
  cv::Mat target_rgb(h, w, CV_32FC3, cv::Scalar::all(kNaN));
  const Eigen::Isometry3d target_from_world = target.camera.world_from_camera.inverse();
  const Eigen::Vector3f source_eye = source.camera.world_from_camera.translation().cast<float>();
  const Eigen::Matrix3f source_rotation = source.camera.world_from_camera.linear().cast<float>();
  const Eigen::Vector3f target_eye = target.camera.world_from_camera.translation().cast<float>();
  std::vector<RayCaster::Hit> hits(static_cast<std::size_t>(w));
  for (int y = 0; y < h; ++y) {
    caster.IntersectCameraRow(source.camera, y, 0, w, hits);
    for (int x = 0; x < w; ++x) {
      const RayCaster::Hit& hit = hits[static_cast<std::size_t>(x)];
      if (!hit.valid || relit.status.at<std::uint8_t>(y, x) != irm::kRelit) continue;
      const Eigen::Vector3f d =
          (source_rotation * source.camera.intrinsics.Unproject({x + 0.5, y + 0.5}).cast<float>()).normalized();
      const Eigen::Vector3f p = source_eye + d * hit.t;
      const Eigen::Vector3d in_target = target_from_world * p.cast<double>();
      if (in_target.z() <= 0.0) continue;
      const Eigen::Vector2d uv = target.camera.intrinsics.Project(in_target);
      const int tx = static_cast<int>(uv.x()), ty = static_cast<int>(uv.y());
      if (uv.x() < 0.0 || uv.y() < 0.0 || tx >= w || ty >= h) continue;
      if (!target.mask.empty() && target.mask.at<std::uint8_t>(ty, tx) != 0) continue;
      if (caster.Occluded(target_eye, p - target_eye, 0.0f, 0.999f)) continue;
      const Eigen::Vector3f rgb = irm::SampleBilinear(target.image->pixels, uv);
      if (!rgb.allFinite() || rgb.minCoeff() <= 0.0f) continue;
      target_rgb.at<cv::Vec3f>(y, x) = cv::Vec3f(rgb.x(), rgb.y(), rgb.z());
    }
  }
  SeamResult seam;
  seam.image = MakeRadianceImage(w, h);
  auto in_overlap = [&](int x, int y) {
    return x >= 0 && y >= 0 && x < w && y < h && std::isfinite(target_rgb.at<cv::Vec3f>(y, x)[0]);
  };
  double ob = 0, oa = 0, sb = 0, sa = 0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (!in_overlap(x, y)) continue;
      const cv::Vec3f& t = target_rgb.at<cv::Vec3f>(y, x);
      const cv::Vec3f& s = source.image->pixels.at<cv::Vec3f>(y, x);
      const cv::Vec3f& r = relit.relit.pixels.at<cv::Vec3f>(y, x);
      double before = 0, after = 0;
      for (int c = 0; c < 3; ++c) {
        before += std::pow((s[c] - t[c]) / t[c], 2) / 3.0;
        after += std::pow((r[c] - t[c]) / t[c], 2) / 3.0;
      }
      const bool on_seam =
          !in_overlap(x - 1, y) || !in_overlap(x + 1, y) || !in_overlap(x, y - 1) || !in_overlap(x, y + 1);
      ob += before;
      oa += after;
      ++seam.overlap_pixels;
      if (on_seam) {
        sb += before;
        sa += after;
        ++seam.seam_pixels;
      }
      seam.image.pixels.at<cv::Vec3f>(y, x) =
          cv::Vec3f(static_cast<float>(std::sqrt(before)), static_cast<float>(std::sqrt(after)), on_seam ? 1.0f : 0.0f);
    }
  }
  if (seam.overlap_pixels > 0) {
    seam.overlap_before = std::sqrt(ob / static_cast<double>(seam.overlap_pixels));
    seam.overlap_after = std::sqrt(oa / static_cast<double>(seam.overlap_pixels));
  }
  if (seam.seam_pixels > 0) {
    seam.seam_before = std::sqrt(sb / static_cast<double>(seam.seam_pixels));
    seam.seam_after = std::sqrt(sa / static_cast<double>(seam.seam_pixels));
  }
  return seam;
}

cv::Mat MaskFromStatus(const cv::Mat& status) {
  if (status.empty()) return {};
  cv::Mat mask;
  cv::compare(status, cv::Scalar(0), mask, cv::CMP_NE);
  return mask;
}

RadianceImage SunImage(const cv::Mat& fractions) {
  RadianceImage image;
  image.pixels = fractions.clone();
  image.pixels.setTo(-1.0f, fractions != fractions);  // no geometry: -1 (NaN never leaves the stage)
  return image;
}

}  // namespace

// ---------------------------------------------------------------------------------------

nlohmann::json IrmSetToJson(const irm::IrmSet& set) {
  return FieldsToJson(set);
}

namespace {

// IrmSet::vertex_indirect_* and vertex_radiance_* (indirect.f32 of irm-build), as mesh.bin
// holds its arrays (WriteVectors: a count, then the values); all empty without indirect light.
void WriteVertexIndirect(const irm::IrmSet& set, const fs::path& path) {
  std::ofstream out(path, std::ios::binary);
  for (const auto* values : {&set.vertex_indirect_source, &set.vertex_indirect_target, &set.vertex_radiance_source,
                             &set.vertex_radiance_target}) {
    WriteVectors(out, *values);
  }
  if (!out) throw IoError(path.string(), "cannot be written (disk full?)");
}

void ReadVertexIndirect(const fs::path& path, irm::IrmSet* set) {
  std::error_code ec;
  const std::uintmax_t bytes = fs::file_size(path, ec);
  if (ec) throw IoError(path.string(), "cannot be read; run with --force");
  std::ifstream in(path, std::ios::binary);
  for (auto* values : {&set->vertex_indirect_source, &set->vertex_indirect_target, &set->vertex_radiance_source,
                       &set->vertex_radiance_target}) {
    ReadVectors(in, bytes, values);
  }
  if (!in) throw IoError(path.string(), "is short or unreadable; run with --force");
}

}  // namespace

irm::IrmSet IrmSetFromJson(const nlohmann::json& json, const std::string& source) {
  irm::IrmSet set = FieldsFromJson<irm::IrmSet>(json, source);
  for (std::size_t k = 0; k < set.maps.size(); ++k) {
    const irm::RatioMap& map = set.maps[k];
    const std::size_t bins = static_cast<std::size_t>(map.bins) * static_cast<std::size_t>(map.bins);
    if (map.count.size() != bins || map.source.size() != bins || map.ratio.size() != bins ||
        map.mean_normal.size() != bins || map.mean_sky_view.size() != bins || map.mean_sky_moment.size() != bins ||
        map.model_ratio.size() != bins) {
      throw InvalidArgumentError(source + ": map " + std::to_string(k) + " has the wrong number of bins");
    }
  }
  return set;
}

cv::Mat GeometryAgreement(const RayCaster& caster, const PinholeCamera& camera, const cv::Mat& truth_depth_m) {
  const int w = camera.intrinsics.width, h = camera.intrinsics.height;
  RELUME_CHECK(truth_depth_m.type() == CV_32FC1 && truth_depth_m.cols == w && truth_depth_m.rows == h);
  cv::Mat agree(h, w, CV_8UC1, cv::Scalar(0));
  std::vector<RayCaster::Hit> hits(static_cast<std::size_t>(w));
  for (int y = 0; y < h; ++y) {
    caster.IntersectCameraRow(camera, y, 0, w, hits);
    for (int x = 0; x < w; ++x) {
      const float depth = truth_depth_m.at<float>(y, x);
      const RayCaster::Hit& hit = hits[static_cast<std::size_t>(x)];
      if (!hit.valid || !std::isfinite(depth)) continue;
      const Eigen::Vector3d d = camera.intrinsics.Unproject({x + 0.5, y + 0.5});
      const double truth_t = depth * d.norm();  // Unproject has z = 1
      if (std::abs(hit.t - truth_t) <= 0.01 * truth_t) agree.at<std::uint8_t>(y, x) = 255;
    }
  }
  return agree;
}

cv::Mat ShadowAgreement(const RayCaster& caster, const PinholeCamera& camera, const cv::Mat& agree,
                        const std::vector<SunCheck>& suns, int sun_samples, float tolerance) {
  const int w = camera.intrinsics.width, h = camera.intrinsics.height;
  RELUME_CHECK(agree.type() == CV_8UC1 && agree.cols == w && agree.rows == h);
  for (const SunCheck& s : suns) {
    RELUME_CHECK(s.truth_sun_visibility != nullptr && s.truth_sun_visibility->type() == CV_32FC1 &&
                 s.truth_sun_visibility->size() == agree.size());
  }
  const float radius = 0.5f * 0.533f * std::numbers::pi_v<float> / 180.0f;  // the world's sun disk
  cv::Mat out = agree.clone();
  const TriangleMesh& mesh = caster.mesh();
  std::vector<RayCaster::Hit> hits(static_cast<std::size_t>(w));
  const Eigen::Vector3f eye = camera.world_from_camera.translation().cast<float>();
  for (int y = 0; y < h; ++y) {
    caster.IntersectCameraRow(camera, y, 0, w, hits);
    for (int x = 0; x < w; ++x) {
      const RayCaster::Hit& hit = hits[static_cast<std::size_t>(x)];
      if (out.at<std::uint8_t>(y, x) == 0 || !hit.valid) continue;
      const Eigen::Vector3f d = (camera.world_from_camera.linear() * camera.intrinsics.Unproject({x + 0.5, y + 0.5}))
                                    .cast<float>()
                                    .normalized();
      const Eigen::Vector3f point = eye + d * hit.t;
      const Eigen::Vector3f normal = caster.Interpolate(mesh.normals, hit).normalized();
      for (const SunCheck& s : suns) {
        // Attached shadow (sun behind the surface): the truth reports 0 and the IRM's maps 1,
        // and neither is a cast shadow to compare.
        if (normal.dot(s.sun_dir) <= 0.0f) continue;
        const float mesh_fraction = SunVisibleFraction(caster, point, normal, s.sun_dir, radius, sun_samples);
        if (std::abs(mesh_fraction - s.truth_sun_visibility->at<float>(y, x)) > tolerance) {
          out.at<std::uint8_t>(y, x) = 0;
          break;
        }
      }
    }
  }
  return out;
}

// The relit source (relight_dir/relit.exr, status.png) against the world rendered from the source
// camera at the target's time, per region (lit, shadow, penumbra), on relit pixels where the mesh
// and the world agree; writes the error image to `error_png`.
IrmTruthRecord CompareIrmWithTruth(const SessionTruth& world, const RayCaster& caster, const irm::View& source,
                                   const irm::View& target, UtcTime source_utc, UtcTime target_utc,
                                   const fs::path& relight_dir, const fs::path& error_png) {
  const GroundTruth truth = world.Render(source.camera, target_utc);
  const GroundTruth source_truth = world.Render(source.camera, source_utc);
  const RadianceImage relit = calibration::LoadRadianceExr((relight_dir / "relit.exr").string());
  const cv::Mat status = cv::imread((relight_dir / "status.png").string(), cv::IMREAD_UNCHANGED);
  if (status.empty()) throw IoError((relight_dir / "status.png").string(), "cannot be read; run with --force");
  cv::Mat use;
  cv::compare(status, cv::Scalar(irm::kRelit), use, cv::CMP_EQ);
  const cv::Mat agree = GeometryAgreement(caster, source.camera, truth.depth_m);
  const cv::Mat shadows_agree = ShadowAgreement(caster, source.camera, agree,
                                                {{source.sun_dir.normalized(), &source_truth.sun_visibility},
                                                 {target.sun_dir.normalized(), &truth.sun_visibility}});
  const int relit_pixels = cv::countNonZero(use);
  use &= agree;
  const int geometry_agrees = cv::countNonZero(use);
  use &= shadows_agree;
  IrmTruthRecord t;
  t.geometry_mismatch_pixels = relit_pixels - geometry_agrees;
  t.shadow_geometry_mismatch_pixels = geometry_agrees - cv::countNonZero(use);
  cv::Mat error_image;
  t.relit = metrics::CompareSunRegions(relit.pixels, truth.radiance.pixels, source_truth.sun_visibility,
                                       truth.sun_visibility, use, metrics::Scale::kFitted, &error_image);
  calibration::SaveImage(error_image, error_png.string());
  t.no_relighting = metrics::CompareSunRegions(source.image->pixels, truth.radiance.pixels, source_truth.sun_visibility,
                                               truth.sun_visibility, use, metrics::Scale::kFitted);
  t.comparison =
      "relit source vs the world rendered from the source camera at the target's time, on relit pixels "
      "where mesh and truth agree; one least-squares scale per image (relative radiance), relative RMS per region";
  // How far the frames' recorded sun is from the world's (both ENU).
  const double angle = std::acos(
      std::clamp(static_cast<double>(target.sun_dir.cast<double>().dot(world.SunDirection(target_utc))), -1.0, 1.0));
  t.target_sun_direction_error_deg = angle * 180.0 / std::numbers::pi;
  return t;
}

// A float image of `truth_dir` that must match the source camera's size.
cv::Mat ExternalTruthImage(const fs::path& truth_dir, const char* name, const PinholeCamera& camera) {
  const fs::path path = truth_dir / name;
  if (!fs::exists(path)) {
    throw IoError(path.string(),
                  "does not exist; --set truth_dir needs target.exr, source_sun.exr and target_sun.exr "
                  "(docs/irm.md)");
  }
  const RadianceImage image = calibration::LoadRadianceExr(path.string());
  if (image.width() != camera.intrinsics.width || image.height() != camera.intrinsics.height) {
    throw InvalidArgumentError(path.string() + " is " + std::to_string(image.width()) + "x" +
                               std::to_string(image.height()) + "; the source camera's photographs are " +
                               std::to_string(camera.intrinsics.width) + "x" +
                               std::to_string(camera.intrinsics.height));
  }
  return image.pixels;
}

// The relit source against a truth made outside relume (`truth_dir`, IrmKnobs::truth_dir): per
// region from the truth's own sun fractions, on relit pixels the truth marks as surface.
IrmTruthRecord CompareIrmWithExternalTruth(const fs::path& truth_dir, const irm::View& source,
                                           const fs::path& relight_dir, const fs::path& error_png) {
  const cv::Mat truth = ExternalTruthImage(truth_dir, "target.exr", source.camera);
  std::vector<cv::Mat> source_sun, target_sun;
  cv::split(ExternalTruthImage(truth_dir, "source_sun.exr", source.camera), source_sun);
  cv::split(ExternalTruthImage(truth_dir, "target_sun.exr", source.camera), target_sun);
  const RadianceImage relit = calibration::LoadRadianceExr((relight_dir / "relit.exr").string());
  const cv::Mat status = cv::imread((relight_dir / "status.png").string(), cv::IMREAD_UNCHANGED);
  if (status.empty()) throw IoError((relight_dir / "status.png").string(), "cannot be read; run with --force");
  cv::Mat use;
  cv::compare(status, cv::Scalar(irm::kRelit), use, cv::CMP_EQ);
  const int relit_pixels = cv::countNonZero(use);
  const cv::Mat both_surfaces = (source_sun[1] > 0.5f) & (target_sun[1] > 0.5f);
  use &= both_surfaces;
  IrmTruthRecord t;
  t.truth = "external: " + truth_dir.string();
  t.relit_pixels_off_the_truths_surfaces = relit_pixels - cv::countNonZero(use);
  cv::Mat error_image;
  t.relit = metrics::CompareSunRegions(relit.pixels, truth, source_sun[0], target_sun[0], use, metrics::Scale::kFitted,
                                       &error_image);
  calibration::SaveImage(error_image, error_png.string());
  t.no_relighting = metrics::CompareSunRegions(source.image->pixels, truth, source_sun[0], target_sun[0], use,
                                               metrics::Scale::kFitted);
  // The floor the relit image inherits: the linearised source photograph against the truth's
  // own source image (optional source.exr), in the same regions.
  if (fs::exists(truth_dir / "source.exr")) {
    const cv::Mat source_truth = ExternalTruthImage(truth_dir, "source.exr", source.camera);
    t.source_photograph = metrics::CompareSunRegions(source.image->pixels, source_truth, source_sun[0], target_sun[0],
                                                     use, metrics::Scale::kFitted);
  }
  t.comparison =
      "relit source vs an external truth of the source camera under the target's light, on relit pixels of its "
      "surfaces; one least-squares scale per image (relative radiance), relative RMS per region of its sun fractions";
  return t;
}

// Without --source and --target: the earliest and the latest complete still bracket of the
// first camera that has two, so the sun has moved the most between them.
std::pair<std::optional<std::string>, std::optional<std::string>> SourceAndTarget(PipelineRun& run) {
  const PipelineRequest& request = run.request();
  if (request.source || request.target) return {request.source, request.target};
  std::map<std::string, std::vector<std::int64_t>> by_device;
  for (const capture::BracketRecord& b : run.session().Brackets()) {
    if (b.status == "complete") by_device[b.device_id].push_back(b.id);
  }
  for (const auto& [device, ids] : by_device) {
    if (ids.size() < 2) continue;
    const std::string source = "bracket:" + std::to_string(ids.front());
    const std::string target = "bracket:" + std::to_string(ids.back());
    run.Decide("irm", "choose",
               "relight " + source + " to " + target + " of " + device +
                   " (the earliest and the latest complete bracket; --source/--target choose others)");
    return {source, target};
  }
  return {std::nullopt, std::nullopt};  // OneBracket says what to give
}

namespace {

// The two photographs as the build, relight and truth stages read them.
struct ViewPair {
  const BracketRadiance& source_radiance;
  const BracketRadiance& target_radiance;
  const irm::View& source;
  const irm::View& target;
  const irm::ViewGeometry& source_geometry;
  const irm::ViewGeometry& target_geometry;
  const StageKey& source_view_key;
  const StageKey& target_view_key;
  const LazyCaster& caster;
};

// Stage irm-build's result.
struct BuildStage {
  StageKey key;
  irm::IrmSet irms;
  irm::RelightSummary summary;
};

// Stage irm-build: the IRMs (one, or four when samples both images see are in cast shadow), the
// decision and the maps as outputs.
BuildStage RunBuildStage(PipelineRun& run, const IrmKnobs& knobs, const ViewPair& v) {
  const irm::RelightOptions& options = knobs.relight;
  BuildStage b;
  b.key.Add("stage", "irm-build-v6").AddKey("source_view", v.source_view_key).AddKey("target_view", v.target_view_key);
  AddKnobsToKey(b.key, knobs, "build");
  b.key.AddKey("source_radiance", v.source_radiance.key).AddKey("target_radiance", v.target_radiance.key);
  b.key.Add("lit", static_cast<double>(options.irm.lit_threshold));
  b.key.Add("shadow", static_cast<double>(options.irm.shadow_threshold));
  b.key.Add("min_samples", options.irm.min_samples_per_bin).Add("trim", static_cast<double>(options.irm.trim_fraction));
  b.key.Add("fill", irm::ToString(options.irm.fill));
  b.summary.preprocess_s = v.source_geometry.seconds + v.target_geometry.seconds;
  const StageStore::Result build = run.RunStage("irm-build", b.key, [&](const fs::path& dir) {
    b.irms = irm::BuildIrmsFromViews(v.caster.get(), v.source, v.target, v.source_geometry, v.target_geometry, options,
                                     &b.summary);
    WriteJsonFile(dir / "irms.json", IrmSetToJson(b.irms));
    WriteVertexIndirect(b.irms, dir / "indirect.f32");
    WriteRecord(dir / "build.json", b.summary);
    for (int k = 0; k < 4; ++k) {
      if (b.irms.single_map && k > 0) break;
      SaveMapImages(b.irms.maps[static_cast<std::size_t>(k)],
                    std::string("irm_") + irm::ToString(static_cast<irm::MapKind>(k)), dir);
    }
  });
  if (build.reused) {
    b.irms = IrmSetFromJson(ReadJsonFile(build.dir / "irms.json"), (build.dir / "irms.json").string());
    ReadVertexIndirect(build.dir / "indirect.f32", &b.irms);
    b.summary = ReadRecord<irm::RelightSummary>(build.dir / "build.json");
  }
  // The decision is the library's (irm::BuildIrms: a sample seen in both images in cast shadow
  // in either), reported as built; the per-view counts are context.
  run.Decide("irm-build", "choose",
             std::string(b.irms.single_map ? "one IRM (lit to lit): no sample seen in both images is in cast shadow"
                                           : "four IRMs: samples seen in both images are in cast shadow") +
                 " (visible vertices in cast shadow: " + std::to_string(v.source_geometry.visible_in_cast_shadow) +
                 " in the source, " + std::to_string(v.target_geometry.visible_in_cast_shadow) + " in the target)");
  run.Decide("irm-build", "note", b.irms.summary);
  for (int k = 0; k < 4; ++k) {
    if (b.irms.single_map && k > 0) break;
    const std::string name = std::string("irm_") + irm::ToString(static_cast<irm::MapKind>(k));
    run.AddOutput(build.dir / (name + ".exr"), "IRM " + std::string(irm::ToString(static_cast<irm::MapKind>(k))) +
                                                   " (ratios per octahedral normal bin; " + name +
                                                   "_count.png: samples per bin)");
  }
  return b;
}

// Stage irm-relight's result: its key, folder and record.
struct RelightStage {
  StageKey key;
  fs::path dir;
  IrmRelightRecord record;
};

// Stage irm-relight: the source relit per pixel to the target's light with the IRMs, previews,
// the status and sun images, and the seam against the target.
RelightStage RunRelightStage(PipelineRun& run, const IrmKnobs& knobs, const ViewPair& v, const BuildStage& b) {
  RelightStage r;
  r.key.Add("stage", "irm-relight-v3").AddKey("build", b.key);
  AddKnobsToKey(r.key, knobs, "relight");
  const StageStore::Result relight = run.RunStage("irm-relight", r.key, [&](const fs::path& dir) {
    const irm::RelightResult result = irm::RelightPixels(v.caster.get(), v.source, v.target, v.source_geometry,
                                                         v.target_geometry, b.irms, knobs.relight, b.summary);
    const double white = WhiteOf(*v.target.image);
    calibration::SaveRadianceExr(result.relit, (dir / "relit.exr").string());
    calibration::SaveImage(RadiancePreview(result.relit, white), (dir / "relit.png").string());
    calibration::SaveImage(RadiancePreview(*v.target.image, white), (dir / "target.png").string());
    calibration::SaveImage(RadiancePreview(*v.source.image, white), (dir / "source.png").string());
    calibration::SaveImage(result.status, (dir / "status.png").string());
    calibration::SaveRadianceExr(SunImage(result.source_sun), (dir / "source_sun.exr").string());
    calibration::SaveRadianceExr(SunImage(result.target_sun), (dir / "target_sun.exr").string());
    const SeamResult seam = Seam(v.caster.get(), v.source, v.target, result);
    calibration::SaveRadianceExr(seam.image, (dir / "seam_difference.exr").string());
    IrmRelightRecord record;
    record.summary = result.summary;
    record.seam = {seam.overlap_pixels, seam.overlap_before, seam.overlap_after,
                   seam.seam_pixels,    seam.seam_before,    seam.seam_after};
    record.preview_white = white;
    WriteRecord(dir / "relight.json", record);
  });
  r.dir = relight.dir;
  r.record = ReadRecord<IrmRelightRecord>(relight.dir / "relight.json");
  run.AddOutput(relight.dir / "relit.exr", "the source relit to the target's light (linear float RGB)");
  run.AddOutput(relight.dir / "relit.png",
                "preview with the target's exposure (target.png, source.png beside it with the same one)");
  run.AddOutput(relight.dir / "status.png",
                "per pixel: 0 no geometry (untouched), 1 relit, 2 no ratio "
                "(untouched), 3 masked: badly exposed (untouched)");
  run.AddOutput(relight.dir / "seam_difference.exr",
                "relative difference to the target where both see a surface: R before, G after, B 1 on the seam");
  return r;
}

// What the relighting did, for the summary: its record, the mesh, the views' counts and sky shapes.
IrmResultFigures ResultFigures(const SceneGeometry& geometry, const MeshStage& mesh, const ViewPair& v,
                               const irm::IrmSet& irms, const IrmRelightRecord& relight) {
  IrmResultFigures r;
  r.relight = relight;
  r.mesh = {geometry.origin, mesh.vertices, mesh.triangles};
  r.visible_in_cast_shadow = {v.source_geometry.visible_in_cast_shadow, v.target_geometry.visible_in_cast_shadow};
  r.single_map = irms.single_map;
  const irm::IndirectShare& share = irms.indirect_share;
  r.indirect.used = !irms.vertex_indirect_source.empty();
  r.indirect.scale = irms.model.indirect_scale;
  r.indirect.reason = irms.model.indirect_reason;
  r.indirect.share_source_lit = share.source_lit;
  r.indirect.share_source_shadow = share.source_shadow;
  r.indirect.share_target_lit = share.target_lit;
  r.indirect.share_target_shadow = share.target_shadow;
  r.sky_shape = {v.source_geometry.sky_shape, v.target_geometry.sky_shape};
  const irm::SkyShape& sky = v.source_geometry.sky_shape;
  if (sky.measured && sky.horizon.minCoeff() > 0.0f) {
    r.indirect.scale_over_sky_prediction =
        (irms.model.indirect_scale.cwiseProduct(sky.horizon) * std::numbers::pi_v<float>).eval();
  }
  return r;
}

// Stage irm-truth: against the truth, the source camera under the target's sun: the simulated
// world's (rendered twice, shadow rays per pixel) or, with --set truth_dir, one made outside
// relume. A stage of its own, keyed by the relit result and the truth.
IrmTruthRecord RunTruthStage(PipelineRun& run, const ViewPair& v, const RelightStage& relight, const StageKey& mesh_key,
                             const std::string& truth_dir) {
  StageKey truth_key;
  truth_key.Add("stage", "irm-truth-v2").AddKey("relight", relight.key).AddKey("mesh", mesh_key);
  truth_key.AddKey("source_radiance", v.source_radiance.key).AddKey("target_radiance", v.target_radiance.key);
  if (!truth_dir.empty()) {
    for (const char* name : {"target.exr", "source_sun.exr", "target_sun.exr", "source.exr"}) {
      const fs::path path = fs::path(truth_dir) / name;
      if (std::string(name) == "source.exr" && !fs::exists(path)) continue;  // optional
      if (!fs::exists(path)) {
        throw IoError(path.string(),
                      "does not exist; --set truth_dir needs target.exr, source_sun.exr and "
                      "target_sun.exr (docs/irm.md)");
      }
      truth_key.AddFileContent(name, path);
    }
  } else {
    truth_key.Add("truth", run.truth()->Key());
  }
  truth_key.Add("source_utc", FormatIso8601(v.source_radiance.utc))
      .Add("target_utc", FormatIso8601(v.target_radiance.utc));
  AddCamera(truth_key, "camera", v.source.camera);
  for (int k = 0; k < 3; ++k) {
    truth_key.Add("source_sun", static_cast<double>(v.source.sun_dir[k]));
    truth_key.Add("target_sun", static_cast<double>(v.target.sun_dir[k]));
  }
  const StageStore::Result truth = run.RunStage("irm-truth", truth_key, [&](const fs::path& dir) {
    WriteRecord(dir / "truth.json",
                truth_dir.empty()
                    ? CompareIrmWithTruth(*run.truth(), v.caster.get(), v.source, v.target, v.source_radiance.utc,
                                          v.target_radiance.utc, relight.dir, dir / "truth_error.png")
                    : CompareIrmWithExternalTruth(truth_dir, v.source, relight.dir, dir / "truth_error.png"));
  });
  fs::copy_file(truth.dir / "truth_error.png", run.out_dir() / "truth_error.png", fs::copy_options::overwrite_existing);
  run.AddOutput(run.out_dir() / "truth_error.png",
                "relative error of the relit source against the truth (white at 10%; blue tint: shadow, red: "
                "penumbra)");
  IrmTruthRecord t = ReadRecord<IrmTruthRecord>(truth.dir / "truth.json");
  char text[200];
  std::snprintf(text, sizeof(text),
                "relit vs %s: relative RMS lit %.4f, shadow %.4f, penumbra %.4f (no "
                "relighting: %.4f, %.4f, %.4f)",
                truth_dir.empty() ? "truth" : "the external truth", t.relit.lit, t.relit.shadow, t.relit.penumbra,
                t.no_relighting.lit, t.no_relighting.shadow, t.no_relighting.penumbra);
  run.Decide("truth", "note", text);
  return t;
}

}  // namespace

IrmSummary RunIrmPipeline(PipelineRun& run) {
  IrmSummary summary;
  const auto [source_selector, target_selector] = SourceAndTarget(run);
  const auto source_bracket = OneBracket(run, source_selector, "source");
  const auto target_bracket = OneBracket(run, target_selector, "target");

  const IrmKnobs knobs = run.ReadKnobs<IrmKnobs>();
  std::string why;
  if (!knobs.IsValid(&why)) throw InvalidArgumentError("irm settings: " + why);
  const irm::RelightOptions& options = knobs.relight;
  const bool compare_truth = knobs.compare_truth;

  const SceneGeometry geometry = LoadGeometry(run, knobs);
  const PinholeCamera source_camera =
      run.RequireCamera(source_bracket.front().device_id, "the irm pipeline's source view").camera;
  const PinholeCamera target_camera =
      run.RequireCamera(target_bracket.front().device_id, "the irm pipeline's target view").camera;
  run.Decide("irm", "plan",
             "relight " + source_bracket.front().device_id + " frame " + std::to_string(source_bracket.front().id) +
                 " to the light of frame " + std::to_string(target_bracket.front().id) + " (mesh: " + geometry.origin +
                 ")");
  if (run.request().explain) return summary;
  const MeshStage mesh = RunMeshStage(run, geometry);
  run.Decide("irm", "note", "the mesh has " + std::to_string(mesh.triangles) + " triangles");

  const BracketRadiance source_radiance = LinearRadiance(run, source_bracket);
  const BracketRadiance target_radiance = LinearRadiance(run, target_bracket);
  irm::View source{&source_radiance.radiance, source_camera, SunDirection(source_radiance, "source"),
                   MaskFromStatus(source_radiance.status)};
  irm::View target{&target_radiance.radiance, target_camera, SunDirection(target_radiance, "target"),
                   MaskFromStatus(target_radiance.status)};
  const LazyCaster caster(mesh, source, target, options);
  StageKey source_view_key, target_view_key;
  const irm::ViewGeometry source_geometry =
      ViewStage(run, "source", caster, mesh, source, knobs, geometry.key, source_radiance.key, &source_view_key);
  const irm::ViewGeometry target_geometry =
      ViewStage(run, "target", caster, mesh, target, knobs, geometry.key, target_radiance.key, &target_view_key);
  const ViewPair views{source_radiance, target_radiance, source,          target, source_geometry,
                       target_geometry, source_view_key, target_view_key, caster};
  const BuildStage build = RunBuildStage(run, knobs, views);
  const RelightStage relight = RunRelightStage(run, knobs, views, build);
  summary.irm = ResultFigures(geometry, mesh, views, build.irms, relight.record);
  if (!knobs.truth_dir.empty()) {
    summary.truth = RunTruthStage(run, views, relight, geometry.key, knobs.truth_dir);
  } else if (compare_truth && run.truth() != nullptr) {
    summary.truth = RunTruthStage(run, views, relight, geometry.key, "");
  }
  return summary;
}

namespace {

std::string IrmHeadline(const IrmSummary& s) {
  if (!s.irm) return "";
  std::string text = s.irm->single_map ? "one IRM" : "four IRMs";
  if (s.truth) {
    const metrics::SunRegionErrors& a = s.truth->relit;
    const metrics::SunRegionErrors& b = s.truth->no_relighting;
    text += "; against the truth: lit " + PercentText(a.lit) + ", shadow " + PercentText(a.shadow) + ", penumbra " +
            PercentText(a.penumbra) + " (not relit: " + PercentText(b.lit) + ", " + PercentText(b.shadow) + ", " +
            PercentText(b.penumbra) + ")";
  } else {
    const IrmSeamFigures& seam = s.irm->relight.seam;
    text += "; where both photographs see a surface, relit vs target " + PercentText(seam.overlap_relative_rms_after) +
            " (before " + PercentText(seam.overlap_relative_rms_before) + ")";
  }
  return text;
}

std::vector<Figure> IrmFigures(const IrmSummary& s) {
  std::vector<Figure> f;
  if (s.truth) {
    const IrmTruthRecord& t = *s.truth;
    const auto region = [&](const char* name, double relit, double not_relit, std::int64_t pixels) {
      AddFigure(f, std::string("relit vs truth, ") + name + " (per-pixel relative RMS)", relit, "%");
      AddFigure(f, std::string("not relit vs truth, ") + name, not_relit, "%");
      AddFigure(f, std::string("pixels compared, ") + name, static_cast<double>(pixels), "", 9);
    };
    region("lit", t.relit.lit, t.no_relighting.lit, t.relit.lit_pixels);
    region("shadow", t.relit.shadow, t.no_relighting.shadow, t.relit.shadow_pixels);
    region("penumbra", t.relit.penumbra, t.no_relighting.penumbra, t.relit.penumbra_pixels);
    AddFigure(f, "recorded sun direction vs the world's", t.target_sun_direction_error_deg, "deg", 3);
  }
  if (s.irm) {
    const IrmSeamFigures& seam = s.irm->relight.seam;
    AddFigure(f, "relit vs target where both see a surface", seam.overlap_relative_rms_after, "%");
    AddFigure(f, "source vs target there (before)", seam.overlap_relative_rms_before, "%");
    AddFigure(f, "pixels relit", static_cast<double>(s.irm->relight.summary.pixels_relit), "", 9);
    AddFigure(f, "mesh triangles", static_cast<double>(s.irm->mesh.triangles), "", 9);
  }
  return f;
}

}  // namespace

PipelineEntry IrmPipelineEntry() {
  return MakePipelineEntry(TypedPipeline<IrmSummary>{
      "irm",
      "relight a still bracket (--source) to the light of another (--target) with irradiance ratio maps",
      RunIrmPipeline,
      WithRadianceKnobs(DescribeKnobs<IrmKnobs>()),
      IrmHeadline,
      IrmFigures,
      {"radiance", "mesh", "view", "build", "relight"}});
}

}  // namespace relume::pipeline
