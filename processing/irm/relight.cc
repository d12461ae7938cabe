#include "processing/irm/relight.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <mutex>
#include <unordered_map>

#include "core/error.h"
#include "core/parallel.h"
#include "processing/irm/indirect.h"

namespace relume::irm {

namespace {

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The sun's visible fraction at a surface point, over the disk's directions (SunDiskDirections,
// computed once per photograph).
float SunFractionAt(const RayCaster& caster, const Eigen::Vector3f& point, const Eigen::Vector3f& normal,
                    const Eigen::Vector3f& sun_dir, const std::vector<Eigen::Vector3f>& disk) {
  if (normal.dot(sun_dir) <= 0.0f) return 1.0f;  // attached shadow, as VertexSunFractions
  return SunVisibleFraction(caster, point, normal, disk);
}

int StateOf(float fraction, const IrmOptions& o) {
  return fraction >= o.lit_threshold ? 1 : (fraction <= o.shadow_threshold ? 0 : -1);
}

// Radiance at a vertex's projection, read only when the four pixels that the bilinear
// interpolation mixes all see the vertex's own surface (same normal, nearby point) in the same
// sun state: never across a crease, an occlusion edge or a shadow edge.
bool ConsistentSample(const RayCaster& caster, const View& view, const Eigen::Isometry3d& camera_from_world,
                      const std::vector<Eigen::Vector3f>& disk, std::size_t vertex, float vertex_fraction,
                      const RelightOptions& options, Eigen::Vector3f* rgb) {
  const TriangleMesh& mesh = caster.mesh();
  const Eigen::Vector3f& p = mesh.positions[vertex];
  const Eigen::Vector3f& n = mesh.normals[vertex];
  const int state = StateOf(vertex_fraction, options.irm);
  if (state < 0) return false;
  const Eigen::Vector3d in_camera = camera_from_world * p.cast<double>();
  const Eigen::Vector2d uv = view.camera.intrinsics.Project(in_camera);
  const int x0 = static_cast<int>(std::floor(uv.x() - 0.5)), y0 = static_cast<int>(std::floor(uv.y() - 0.5));
  if (!view.mask.empty()) {
    for (int dy = 0; dy <= 1; ++dy) {
      for (int dx = 0; dx <= 1; ++dx) {
        const int x = x0 + dx, y = y0 + dy;
        if (x < 0 || y < 0 || x >= view.mask.cols || y >= view.mask.rows || view.mask.at<std::uint8_t>(y, x) != 0) {
          return false;
        }
      }
    }
  }
  const float footprint = static_cast<float>(in_camera.z() / view.camera.intrinsics.fx);
  const Eigen::Vector3f eye = view.camera.world_from_camera.translation().cast<float>();
  for (int dy = 0; dy <= 1; ++dy) {
    for (int dx = 0; dx <= 1; ++dx) {
      const Eigen::Vector3f d =
          (view.camera.world_from_camera.linear() * view.camera.intrinsics.Unproject({x0 + dx + 0.5, y0 + dy + 0.5}))
              .cast<float>()
              .normalized();
      const RayCaster::Hit hit = caster.Intersect(eye, d, 0.0f, std::numeric_limits<float>::infinity());
      if (!hit.valid) return false;
      const Eigen::Vector3f hit_normal = caster.Interpolate(mesh.normals, hit).normalized();
      const Eigen::Vector3f hit_point = eye + d * hit.t;
      // The vertex's own surface: the same normal, the same plane (within a footprint), and
      // within three footprints of the vertex on it, a footprint stretched by the obliquity of
      // the view up to 2.5x (ground seen from a few metres up spans many footprints per pixel;
      // unstretched, no ground sample survived on 5 of 30 random scenes, docs/benchmarks.md;
      // stretched without a cap, the samples at grazing angles mixed too much of the
      // neighbourhood on the simulated world: shadow 0.95 % -> 1.12 %).
      const Eigen::Vector3f offset = hit_point - p;
      const float obliquity = std::max(0.4f, std::abs(d.dot(n)));
      if (hit_normal.dot(n) < 0.999f || std::abs(offset.dot(n)) > footprint ||
          offset.norm() > 3.0f * footprint / obliquity) {
        return false;
      }
      if (StateOf(SunFractionAt(caster, hit_point, hit_normal, view.sun_dir, disk), options.irm) != state) {
        return false;
      }
    }
  }
  *rgb = SampleBilinear(view.image->pixels, uv);
  return rgb->allFinite();
}

}  // namespace

Eigen::Vector3f SampleBilinear(const cv::Mat& image, const Eigen::Vector2d& point) {
  const double x = point.x() - 0.5, y = point.y() - 0.5;  // pixel centres at +0.5
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  if (x0 < 0 || y0 < 0 || x0 + 1 >= image.cols || y0 + 1 >= image.rows) {
    return Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());
  }
  const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
  auto at = [&](int yy, int xx) {
    const cv::Vec3f& v = image.at<cv::Vec3f>(yy, xx);
    return Eigen::Vector3f(v[0], v[1], v[2]);
  };
  return (1 - fy) * ((1 - fx) * at(y0, x0) + fx * at(y0, x0 + 1)) +
         fy * ((1 - fx) * at(y0 + 1, x0) + fx * at(y0 + 1, x0 + 1));
}

bool RelightOptions::IsValid(std::string* why) const {
  if (!irm.IsValid(why)) return false;
  if (sun_samples < 1 || sun_samples > 4096) {
    if (why) *why = "sun_samples must be within 1..4096";
    return false;
  }
  if (!(sun_angular_radius_rad >= 0.0f && sun_angular_radius_rad < 0.1f)) {
    if (why) *why = "sun angular radius must be within [0, 0.1) rad";
    return false;
  }
  if (sky_samples < 0 || sky_samples > 65536) {
    if (why) *why = "sky_samples must be within 0..65536 (0: no sky view)";
    return false;
  }
  if (indirect_samples < 1 || indirect_samples > 65536) {
    if (why) *why = "indirect_samples must be within 1..65536";
    return false;
  }
  if (indirect_passes < 1 || indirect_passes > 16) {
    if (why) *why = "indirect_passes must be within 1..16";
    return false;
  }
  if (threads < 0 || threads > 256) {
    if (why) *why = "threads must be within 0..256 (0: the CPUs this process may use)";
    return false;
  }
  return true;
}

std::vector<std::uint8_t> VertexVisibility(const RayCaster& caster, const PinholeCamera& camera) {
  const TriangleMesh& mesh = caster.mesh();
  const Eigen::Isometry3d camera_from_world = camera.world_from_camera.inverse();
  const Eigen::Vector3f eye = camera.world_from_camera.translation().cast<float>();
  std::vector<std::uint8_t> visible(mesh.vertex_count(), 0);
  for (std::size_t i = 0; i < mesh.vertex_count(); ++i) {
    const Eigen::Vector3f& p = mesh.positions[i];
    const Eigen::Vector3d in_camera = camera_from_world * p.cast<double>();
    if (in_camera.z() <= 0.0) continue;
    const Eigen::Vector2d uv = camera.intrinsics.Project(in_camera);
    if (uv.x() < 1.0 || uv.y() < 1.0 || uv.x() > camera.intrinsics.width - 1.0 ||
        uv.y() > camera.intrinsics.height - 1.0) {
      continue;
    }
    const Eigen::Vector3f to_eye = eye - p;
    if (mesh.normals[i].dot(to_eye) <= 0.0f) continue;
    const Eigen::Vector3f origin = p + mesh.normals[i] * (4.0f * caster.epsilon());
    visible[i] = caster.Occluded(origin, eye - origin, 0.0f, 0.999f) ? 0 : 1;
  }
  return visible;
}

std::vector<std::uint8_t> VerticesNearView(const TriangleMesh& mesh, const PinholeCamera& camera) {
  const Eigen::Isometry3d camera_from_world = camera.world_from_camera.inverse();
  const double w = camera.intrinsics.width, h = camera.intrinsics.height;
  std::vector<std::uint8_t> near(mesh.vertex_count(), 0);
  for (std::size_t i = 0; i < mesh.vertex_count(); ++i) {
    const Eigen::Vector3d in_camera = camera_from_world * mesh.positions[i].cast<double>();
    if (in_camera.z() <= 0.0) continue;
    const Eigen::Vector2d uv = camera.intrinsics.Project(in_camera);
    near[i] = uv.x() >= -0.5 * w && uv.x() <= 1.5 * w && uv.y() >= -0.5 * h && uv.y() <= 1.5 * h;
  }
  return near;
}

std::vector<float> VertexSunFractions(const RayCaster& caster, const Eigen::Vector3f& sun_dir, int samples,
                                      float angular_radius_rad, int threads, const std::vector<std::uint8_t>* needed) {
  const TriangleMesh& mesh = caster.mesh();
  std::vector<float> fractions(mesh.vertex_count(), 1.0f);
  const Eigen::Vector3f sun = sun_dir.normalized();
  const std::vector<Eigen::Vector3f> disk = SunDiskDirections(sun, angular_radius_rad, samples);
  ParallelForEach(
      0, static_cast<std::int64_t>(mesh.vertex_count()),
      [&](std::int64_t i) {
        const auto k = static_cast<std::size_t>(i);
        if (needed != nullptr && (*needed)[k] == 0) {
          fractions[k] = std::numeric_limits<float>::quiet_NaN();
          return;
        }
        const Eigen::Vector3f& n = mesh.normals[k];
        if (n.dot(sun) <= 0.0f) return;  // attached shadow: reported as 1 (the sun term is zero)
        fractions[k] = SunVisibleFraction(caster, mesh.positions[k], n, disk);
      },
      threads);
  return fractions;
}

std::vector<float> VertexSkyViews(const RayCaster& caster, int samples, int threads,
                                  const std::vector<std::uint8_t>* needed, std::vector<float>* zenith_moments) {
  const TriangleMesh& mesh = caster.mesh();
  std::vector<float> sky(mesh.vertex_count(), std::numeric_limits<float>::quiet_NaN());
  if (zenith_moments != nullptr) zenith_moments->assign(mesh.vertex_count(), std::numeric_limits<float>::quiet_NaN());
  ParallelForEach(
      0, static_cast<std::int64_t>(mesh.vertex_count()),
      [&](std::int64_t i) {
        const auto k = static_cast<std::size_t>(i);
        if (needed != nullptr && (*needed)[k] == 0) return;
        const SkyView view = SkyViewMoments(caster, mesh.positions[k], mesh.normals[k], samples);
        sky[k] = view.view;
        if (zenith_moments != nullptr) (*zenith_moments)[k] = view.zenith_moment;
      },
      threads);
  return sky;
}

void CheckRelightInputs(const RayCaster& caster, const View& source, const View& target,
                        const RelightOptions& options) {
  ThrowIfInvalid(options, "IRM relighting options");
  const TriangleMesh& mesh = caster.mesh();
  if (mesh.normals.size() != mesh.vertex_count())
    throw InvalidArgumentError("IRM relighting: the mesh needs vertex normals");
  for (const View* view : {&source, &target}) {
    std::string why;
    if (!view->image || !view->image->IsValid(&why) || view->image->pixels.type() != CV_32FC3) {
      throw InvalidArgumentError("IRM relighting: each view needs an RGB float radiance image");
    }
    if (!view->camera.intrinsics.IsValid(&why)) throw InvalidArgumentError("IRM relighting: camera: " + why);
    if (view->image->width() != view->camera.intrinsics.width ||
        view->image->height() != view->camera.intrinsics.height) {
      throw InvalidArgumentError("IRM relighting: image size differs from its camera's");
    }
    if (!view->sun_dir.allFinite() || view->sun_dir.norm() < 0.5f) {
      throw InvalidArgumentError("IRM relighting: the sun direction must be a unit vector");
    }
    if (!view->mask.empty() && (view->mask.type() != CV_8UC1 || view->mask.size() != view->image->pixels.size())) {
      throw InvalidArgumentError("IRM relighting: a mask must be 8-bit, one channel, of the image's size");
    }
  }
}

ViewGeometry ComputeViewGeometry(const RayCaster& caster, const View& view, const RelightOptions& options,
                                 bool with_sky_view) {
  const auto start = std::chrono::steady_clock::now();
  ViewGeometry geometry;
  geometry.visible = VertexVisibility(caster, view.camera);
  const std::vector<std::uint8_t> near = VerticesNearView(caster.mesh(), view.camera);
  geometry.sun_fraction = VertexSunFractions(caster, view.sun_dir, options.sun_samples, options.sun_angular_radius_rad,
                                             options.threads, &near);
  if (with_sky_view && options.sky_samples > 0)
    geometry.sky_view = VertexSkyViews(caster, options.sky_samples, options.threads, &near, &geometry.sky_moment);
  if (options.sky_samples > 0 && options.sky_gradient) {
    geometry.sky_shape =
        FitSkyShape(caster, view.image->pixels, view.camera, view.mask, view.sun_dir.normalized(), options.sky_shape);
  } else {
    geometry.sky_shape.reason = options.sky_samples > 0 ? "sky_gradient is off" : "no sky views (sky_samples 0)";
  }
  if (!options.use_penumbra_fractions) {
    for (float& f : geometry.sun_fraction) {
      if (!std::isnan(f)) f = f >= 0.5f ? 1.0f : 0.0f;
    }
  }
  for (std::size_t i = 0; i < geometry.visible.size(); ++i) {
    if (geometry.visible[i] && geometry.sun_fraction[i] < options.irm.lit_threshold) ++geometry.visible_in_cast_shadow;
  }
  geometry.seconds = SecondsSince(start);
  return geometry;
}

namespace {

// What a photograph shows at the vertices it sees, read as the IRM samples are
// (ConsistentSample: only where the four pixels mixed see the vertex's own surface in its sun
// state); NaN elsewhere: where it does not see the vertex, the pixel is masked, or the vertex
// lies on a crease, occlusion or shadow edge, whose mixed pixels would lend it the light of the
// surface beside it (a strip of shadow at a wall's foot, a few pixels at a grazing view, read
// as lit ground: the wall's light from it overestimated by half on the simulated building).
// `known`: the vertices already read (their values in `out`).
void ObservedVertexRadiance(const RayCaster& caster, const View& view, const ViewGeometry& geometry,
                            const RelightOptions& options, const std::vector<std::uint8_t>& known,
                            std::vector<Eigen::Vector3f>* out) {
  const TriangleMesh& mesh = caster.mesh();
  const Eigen::Isometry3d camera_from_world = view.camera.world_from_camera.inverse();
  const std::vector<Eigen::Vector3f> disk =
      SunDiskDirections(view.sun_dir, options.sun_angular_radius_rad, options.sun_samples);
  ParallelForEach(
      0, static_cast<std::int64_t>(mesh.vertex_count()),
      [&](std::int64_t k) {
        const auto i = static_cast<std::size_t>(k);
        if (known[i] || !geometry.visible[i]) return;
        Eigen::Vector3f rgb;
        if (ConsistentSample(caster, view, camera_from_world, disk, i, geometry.sun_fraction[i], options, &rgb) &&
            rgb.minCoeff() >= 0.0f) {
          (*out)[i] = rgb;
        }
      },
      options.threads, 256);
}

// Per-vertex inputs of the model's irradiance for the vertices the gather reads: sun fractions
// (the views' where they have one, else one ray to the sun's centre), the source's sky views
// and moments (NaN: the open plane).
struct VertexLight {
  std::vector<float> source_sun, target_sun, sky_view, sky_moment;
};

VertexLight VertexLightFor(const RayCaster& caster, const View& source, const View& target,
                           const ViewGeometry& source_geometry, const ViewGeometry& target_geometry,
                           const std::vector<std::uint8_t>& use, int threads) {
  const TriangleMesh& mesh = caster.mesh();
  const std::size_t n = mesh.vertex_count();
  VertexLight light;
  light.source_sun.assign(n, std::nanf(""));
  light.target_sun.assign(n, std::nanf(""));
  light.sky_view.assign(n, std::nanf(""));
  light.sky_moment.assign(n, std::nanf(""));
  const std::vector<Eigen::Vector3f> source_centre{source.sun_dir.normalized()};
  const std::vector<Eigen::Vector3f> target_centre{target.sun_dir.normalized()};
  ParallelForEach(
      0, static_cast<std::int64_t>(n),
      [&](std::int64_t i) {
        const auto k = static_cast<std::size_t>(i);
        if (!use[k]) return;
        const Eigen::Vector3f normal = mesh.normals[k].normalized();
        auto fraction = [&](float given, const std::vector<Eigen::Vector3f>& centre) {
          if (std::isfinite(given)) return given;
          return SunFractionAt(caster, mesh.positions[k], normal, centre[0], centre);
        };
        light.source_sun[k] = fraction(source_geometry.sun_fraction[k], source_centre);
        light.target_sun[k] = fraction(target_geometry.sun_fraction[k], target_centre);
        if (!source_geometry.sky_view.empty()) light.sky_view[k] = source_geometry.sky_view[k];
        if (!source_geometry.sky_moment.empty()) light.sky_moment[k] = source_geometry.sky_moment[k];
      },
      threads, 256);
  return light;
}

// The radiance of every vertex the gather reads, in each photograph: what the photograph shows
// where it sees the vertex (ObservedVertexRadiance), else the vertex's albedo times the model's
// irradiance there, indirect light included. Albedo is in the photographs' units per model unit:
// the vertex's own from the other photograph where that one sees it, else a neighbour's (below).
void FillRadiance(const TriangleMesh& mesh, const SunSkyModel& model, const VertexLight& light,
                  const std::vector<std::uint8_t>& use, const std::vector<Eigen::Vector3f>& observed_source,
                  const std::vector<Eigen::Vector3f>& observed_target,
                  const std::vector<Eigen::Vector3f>& indirect_source,
                  const std::vector<Eigen::Vector3f>& indirect_target, std::vector<Eigen::Vector3f>* radiance_source,
                  std::vector<Eigen::Vector3f>* radiance_target, int* filled_source, int* filled_target) {
  const std::size_t n = mesh.vertex_count();
  // Each seen vertex's albedo. An unseen one takes the albedo of the nearest seen vertex of its
  // own part (TriangleMesh::part: an object of the scene model) within kReach_m, one facing the
  // same way first; else its part's median (a building's hidden back from its visible faces, the
  // ground behind it from the ground around); without parts, the nearest seen vertex within
  // kReach_m (facing the same way first); else the median of the vertices the source sees.
  constexpr float kCell_m = 1.0f, kReach_m = 3.0f;
  const bool parts = mesh.part.size() == n;
  auto part_of = [&](std::size_t i) { return parts ? mesh.part[i] : 0; };
  std::vector<Eigen::Vector3f> e_source(n), e_target(n);
  std::vector<Eigen::Vector3f> albedo(n, Eigen::Vector3f::Constant(std::nanf("")));
  std::unordered_map<std::int64_t, std::vector<std::uint32_t>> grid;
  std::unordered_map<int, std::array<std::vector<float>, 3>> part_albedos;
  std::array<std::vector<float>, 3> source_albedos;
  auto cell_of = [&](const Eigen::Vector3f& p) {
    return Eigen::Vector3i(static_cast<int>(std::floor(p.x() / kCell_m)), static_cast<int>(std::floor(p.y() / kCell_m)),
                           static_cast<int>(std::floor(p.z() / kCell_m)));
  };
  auto key_of = [](const Eigen::Vector3i& c) {
    return (static_cast<std::int64_t>(c.x() & 0x1fffff) << 42) | (static_cast<std::int64_t>(c.y() & 0x1fffff) << 21) |
           static_cast<std::int64_t>(c.z() & 0x1fffff);
  };
  for (std::size_t i = 0; i < n; ++i) {
    if (!use[i]) continue;
    model.Irradiance(mesh.normals[i].normalized(), light.source_sun[i], light.target_sun[i], light.sky_view[i],
                     light.sky_moment[i], indirect_source[i], indirect_target[i], &e_source[i], &e_target[i]);
    if (observed_source[i].allFinite() && e_source[i].minCoeff() > 0.05f) {
      albedo[i] = observed_source[i].cwiseQuotient(e_source[i]);
      for (int c = 0; c < 3; ++c) source_albedos[static_cast<std::size_t>(c)].push_back(albedo[i][c]);
    } else if (observed_target[i].allFinite() && e_target[i].minCoeff() > 0.05f) {
      albedo[i] = observed_target[i].cwiseQuotient(e_target[i]);
    }
    if (!albedo[i].allFinite()) continue;
    grid[key_of(cell_of(mesh.positions[i]))].push_back(static_cast<std::uint32_t>(i));
    auto& channels = part_albedos[part_of(i)];
    for (int c = 0; c < 3; ++c) channels[static_cast<std::size_t>(c)].push_back(albedo[i][c]);
  }
  auto median_of = [](std::array<std::vector<float>, 3>& channels) {
    Eigen::Vector3f m = Eigen::Vector3f::Zero();
    for (int c = 0; c < 3; ++c) {
      std::vector<float>& v = channels[static_cast<std::size_t>(c)];
      if (v.empty()) continue;
      std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
      m[c] = v[v.size() / 2];
    }
    return m;
  };
  const Eigen::Vector3f median = median_of(source_albedos);
  std::unordered_map<int, Eigen::Vector3f> part_median;
  for (auto& [part, channels] : part_albedos) part_median[part] = median_of(channels);
  auto nearest_albedo = [&](std::size_t i) -> Eigen::Vector3f {
    const Eigen::Vector3f& p = mesh.positions[i];
    const Eigen::Vector3f normal = mesh.normals[i].normalized();
    const int part = part_of(i);
    const Eigen::Vector3i centre = cell_of(p);
    float best_same = kReach_m * kReach_m, best_any = kReach_m * kReach_m;
    std::int64_t same = -1, any = -1;
    const int shells = static_cast<int>(std::ceil(kReach_m / kCell_m));
    for (int dz = -shells; dz <= shells; ++dz) {
      for (int dy = -shells; dy <= shells; ++dy) {
        for (int dx = -shells; dx <= shells; ++dx) {
          const auto it = grid.find(key_of(centre + Eigen::Vector3i(dx, dy, dz)));
          if (it == grid.end()) continue;
          for (const std::uint32_t j : it->second) {
            if (part_of(j) != part) continue;
            const float d2 = (mesh.positions[j] - p).squaredNorm();
            if (d2 < best_any) best_any = d2, any = j;
            if (d2 < best_same && mesh.normals[j].dot(normal) > 0.9f) best_same = d2, same = j;
          }
        }
      }
    }
    if (same >= 0) return albedo[static_cast<std::size_t>(same)];
    if (parts) {
      const auto it = part_median.find(part);
      if (it != part_median.end()) return it->second;
    }
    if (any >= 0) return albedo[static_cast<std::size_t>(any)];
    return median;
  };
  radiance_source->assign(n, Eigen::Vector3f::Zero());
  radiance_target->assign(n, Eigen::Vector3f::Zero());
  *filled_source = *filled_target = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!use[i]) continue;
    const bool seen_source = observed_source[i].allFinite(), seen_target = observed_target[i].allFinite();
    if (seen_source && seen_target) {
      (*radiance_source)[i] = observed_source[i];
      (*radiance_target)[i] = observed_target[i];
      continue;
    }
    const Eigen::Vector3f rho = albedo[i].allFinite() ? albedo[i] : nearest_albedo(i);
    (*radiance_source)[i] = seen_source ? observed_source[i] : rho.cwiseProduct(e_source[i].cwiseMax(0.0f));
    (*radiance_target)[i] = seen_target ? observed_target[i] : rho.cwiseProduct(e_target[i].cwiseMax(0.0f));
    *filled_source += !seen_source;
    *filled_target += !seen_target;
  }
}

// The median target / source ratio per channel of the samples in shadow (sun fraction at or
// below the shadow threshold) in both photographs, else of all samples: a first guess of K_t.
Eigen::Vector3f ShadowRatio(std::span<const Sample> samples, const IrmOptions& options) {
  std::array<std::vector<float>, 3> shadow, all;
  for (const Sample& s : samples) {
    if (!s.source_rgb.allFinite() || !s.target_rgb.allFinite() || s.source_rgb.minCoeff() <= 0.0f) continue;
    const bool in_shadow = s.source_sun <= options.shadow_threshold && s.target_sun <= options.shadow_threshold;
    for (int c = 0; c < 3; ++c) {
      const float ratio = s.target_rgb[c] / s.source_rgb[c];
      all[static_cast<std::size_t>(c)].push_back(ratio);
      if (in_shadow) shadow[static_cast<std::size_t>(c)].push_back(ratio);
    }
  }
  Eigen::Vector3f out = Eigen::Vector3f::Ones();
  for (int c = 0; c < 3; ++c) {
    std::vector<float>& v = shadow[0].empty() ? all[static_cast<std::size_t>(c)] : shadow[static_cast<std::size_t>(c)];
    if (v.empty()) continue;
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    out[c] = v[v.size() / 2];
  }
  return out;
}

}  // namespace

IrmSet BuildIrmsFromViews(const RayCaster& caster, const View& source, const View& target,
                          const ViewGeometry& source_geometry, const ViewGeometry& target_geometry,
                          const RelightOptions& options, RelightSummary* summary) {
  const auto start = std::chrono::steady_clock::now();
  const TriangleMesh& mesh = caster.mesh();
  RELUME_CHECK(source_geometry.visible.size() == mesh.vertex_count() &&
               target_geometry.visible.size() == mesh.vertex_count());
  summary->vertices = static_cast<int>(mesh.vertex_count());
  const Eigen::Isometry3d source_from_world = source.camera.world_from_camera.inverse();
  const Eigen::Isometry3d target_from_world = target.camera.world_from_camera.inverse();
  const std::vector<Eigen::Vector3f> source_disk =
      SunDiskDirections(source.sun_dir, options.sun_angular_radius_rad, options.sun_samples);
  const std::vector<Eigen::Vector3f> target_disk =
      SunDiskDirections(target.sun_dir, options.sun_angular_radius_rad, options.sun_samples);
  std::vector<std::size_t> both;
  for (std::size_t i = 0; i < mesh.vertex_count(); ++i) {
    if (source_geometry.visible[i] && target_geometry.visible[i]) both.push_back(i);
  }
  summary->visible_in_both = static_cast<int>(both.size());
  std::vector<Sample> candidates(both.size());
  std::vector<std::uint8_t> keep(both.size(), 0);
  ParallelForEach(
      0, static_cast<std::int64_t>(both.size()),
      [&](std::int64_t k) {
        const std::size_t i = both[static_cast<std::size_t>(k)];
        Sample& s = candidates[static_cast<std::size_t>(k)];
        s.normal = mesh.normals[i];
        s.source_sun = source_geometry.sun_fraction[i];
        s.target_sun = target_geometry.sun_fraction[i];
        if (!source_geometry.sky_view.empty()) s.sky_view = source_geometry.sky_view[i];
        if (!source_geometry.sky_moment.empty()) s.sky_moment = source_geometry.sky_moment[i];
        keep[static_cast<std::size_t>(k)] =
            ConsistentSample(caster, source, source_from_world, source_disk, i, s.source_sun, options, &s.source_rgb) &&
            ConsistentSample(caster, target, target_from_world, target_disk, i, s.target_sun, options, &s.target_rgb);
      },
      options.threads);
  std::vector<Sample> samples;
  std::vector<std::size_t> sample_vertex;
  for (std::size_t k = 0; k < both.size(); ++k) {
    if (keep[k]) {
      samples.push_back(candidates[k]);
      sample_vertex.push_back(both[k]);
    }
  }
  summary->consistent_samples = static_cast<int>(samples.size());
  // Each photograph's sky shape (zero, a uniform sky, where it was not measured) and sky
  // radiance at the horizon (zero where not measured: BuildIrms falls back on the measured sky
  // ratio only when its free fit fails).
  const Eigen::Vector3f source_sky =
      source_geometry.sky_shape.measured ? source_geometry.sky_shape.horizon : Eigen::Vector3f::Zero().eval();
  const Eigen::Vector3f target_sky =
      target_geometry.sky_shape.measured ? target_geometry.sky_shape.horizon : Eigen::Vector3f::Zero().eval();
  IrmSet irms =
      BuildIrms(samples, source.sun_dir.normalized(), target.sun_dir.normalized(), options.irm,
                source_geometry.sky_shape.gradient, target_geometry.sky_shape.gradient, source_sky, target_sky);
  // Indirect light needs the sky views: the light a surface gathers from others comes along the
  // rays its sky view finds blocked, and without them (sky_samples 0, the paper's open sky) the
  // model's sky term is off by what a fitted q would only absorb (`relume bench --stage irm`:
  // used, 0.23 s, the relit error unchanged).
  if (options.indirect && irms.model.valid && source_geometry.sky_view.empty()) {
    irms.summary += "; indirect light not gathered: no sky views (sky_samples 0)";
  }
  // Without a valid model the light from the other surfaces is still tried when the source's
  // sky is measured (it fixes the indirect light's scale, irm.h): the first pass fills the
  // radiance of the vertices no photograph shows from the sky alone (no sun; K_t measured, or
  // without the target's sky the median ratio of the samples in shadow in both photographs), and
  // the model is fitted with the indirect light that gives. Under interreflection a sun + sky
  // model without it can fail outright, and without the target's sky BuildIrms has no measured
  // K_t to fall back on (1 of the 20 quick scenes of the IRM suite with bounces, seed 1).
  const bool source_sky_measured = source_sky.minCoeff() > 0.0f;
  if (options.indirect && (irms.model.valid || source_sky_measured) && !source_geometry.sky_view.empty()) {
    SunSkyModel first_fill = irms.model;
    if (!first_fill.valid) {
      first_fill = SunSkyModel{};
      first_fill.valid = true;
      first_fill.sun_dir_source = source.sun_dir.normalized();
      first_fill.sun_dir_target = target.sun_dir.normalized();
      first_fill.sky_target = target_sky.minCoeff() > 0.0f ? target_sky.cwiseQuotient(source_sky).eval()
                                                           : ShadowRatio(samples, options.irm);
      first_fill.sky_gradient_source = source_geometry.sky_shape.gradient;
      first_fill.sky_gradient_target = target_geometry.sky_shape.gradient;
    }
    // Interreflection: each vertex's light from the other surfaces, gathered from what the
    // photographs show (indirect.h), then the model refitted with it; the radiance of surfaces
    // a photograph does not show comes from the model, so each pass refines it. First for the
    // samples' vertices alone, which decide whether the photographs hold interreflection at all
    // (a scene without it costs a few thousand vertices' rays, not the view's hundreds of
    // thousands: 0.28 s instead of 1.6 s on the demo); then, when they do, for every vertex a
    // pixel interpolates from, and the model refitted once more with those.
    const auto indirect_start = std::chrono::steady_clock::now();
    const std::size_t n = mesh.vertex_count();
    auto build = [&](const std::vector<Sample>& with) {
      return BuildIrms(with, source.sun_dir.normalized(), target.sun_dir.normalized(), options.irm,
                       source_geometry.sky_shape.gradient, target_geometry.sky_shape.gradient, source_sky, target_sky);
    };
    auto uses_indirect = [](const IrmSet& set) {
      return set.model.valid && (set.model.indirect_scale.array() > 0.0f).any();
    };
    // The samples' readings where both photographs see a vertex; the others read alike.
    std::vector<Eigen::Vector3f> observed_source(n, Eigen::Vector3f::Constant(std::nanf(""))),
        observed_target = observed_source;
    std::vector<std::uint8_t> known(n, 0);
    for (std::size_t k = 0; k < both.size(); ++k) {
      known[both[k]] = 1;
      if (!keep[k]) continue;
      observed_source[both[k]] = candidates[k].source_rgb;
      observed_target[both[k]] = candidates[k].target_rgb;
    }
    ObservedVertexRadiance(caster, source, source_geometry, options, known, &observed_source);
    ObservedVertexRadiance(caster, target, target_geometry, options, known, &observed_target);
    // A gather over `gathered` vertices, and what its fills need (the vertices its rays read).
    struct Gathered {
      IndirectGather gather;
      std::vector<std::uint8_t> use;
      VertexLight light;
    };
    auto gather_over = [&](const std::vector<std::uint8_t>& gathered) {
      Gathered g{IndirectGather::Build(caster, options.indirect_samples, &gathered, options.threads), {}, {}};
      g.use = g.gather.referenced();
      for (std::size_t i = 0; i < n; ++i) g.use[i] = g.use[i] || gathered[i];
      g.light = VertexLightFor(caster, source, target, source_geometry, target_geometry, g.use, options.threads);
      summary->indirect_rays += g.gather.rays();
      summary->indirect_hit_share = g.gather.hit_share();
      return g;
    };
    std::vector<Eigen::Vector3f> indirect_source(n, Eigen::Vector3f::Zero()), indirect_target = indirect_source;
    std::vector<Eigen::Vector3f> radiance_source, radiance_target;
    // One pass: fill with `model`, gather, the samples' light from it.
    auto pass = [&](const Gathered& g, const SunSkyModel& model) {
      FillRadiance(mesh, model, g.light, g.use, observed_source, observed_target, indirect_source, indirect_target,
                   &radiance_source, &radiance_target, &summary->indirect_filled_source,
                   &summary->indirect_filled_target);
      indirect_source = g.gather.Apply(radiance_source);
      indirect_target = g.gather.Apply(radiance_target);
      for (std::size_t k = 0; k < samples.size(); ++k) {
        samples[k].source_indirect = indirect_source[sample_vertex[k]];
        samples[k].target_indirect = indirect_target[sample_vertex[k]];
      }
    };
    std::vector<std::uint8_t> at_samples(n, 0);
    for (std::size_t v : sample_vertex) at_samples[v] = 1;
    {
      const Gathered g = gather_over(at_samples);
      for (int p = 0; p < options.indirect_passes; ++p) {
        pass(g, p == 0 ? first_fill : irms.model);
        IrmSet next = build(samples);
        if (!uses_indirect(next)) {
          // The first pass: the set without indirect light, saying why (BuildIrms). A later one:
          // the last set that fitted with it.
          if (p == 0 && next.model.valid) {
            irms = std::move(next);
          } else {
            irms.summary += "; pass " + std::to_string(p + 1) + " of the indirect light not used: " +
                            (next.model.valid ? next.model.indirect_reason : next.model.reason);
          }
          break;
        }
        irms = std::move(next);
      }
    }
    if (uses_indirect(irms)) {
      // Every vertex a source pixel interpolates from (near the source view) and the target sees.
      std::vector<std::uint8_t> needed(n, 0);
      for (std::size_t i = 0; i < n; ++i) {
        needed[i] = std::isfinite(source_geometry.sun_fraction[i]) || target_geometry.visible[i] || at_samples[i];
      }
      const Gathered g = gather_over(needed);
      for (int p = 0; p < options.indirect_passes; ++p) {  // the unseen vertices' light refined again
        pass(g, irms.model);
        IrmSet next = build(samples);
        if (!uses_indirect(next)) {
          const std::string why = next.model.valid ? next.model.indirect_reason : next.model.reason;
          for (Sample& s : samples) s.source_indirect = s.target_indirect = Eigen::Vector3f::Zero();
          irms = build(samples);
          irms.summary += "; indirect light not used: with every vertex's, " + why;
          break;
        }
        irms = std::move(next);
        irms.vertex_indirect_source = indirect_source;
        irms.vertex_indirect_target = indirect_target;
        irms.vertex_radiance_source = radiance_source;
        irms.vertex_radiance_target = radiance_target;
      }
    }
    if (irms.vertex_indirect_source.empty()) {
      for (Sample& s : samples) s.source_indirect = s.target_indirect = Eigen::Vector3f::Zero();
    }
    summary->indirect_s = SecondsSince(indirect_start);
  }
  summary->irm_summary = irms.summary;
  double before = 0.0, after = 0.0;
  int compared = 0;
  for (const Sample& s : samples) {
    if (!s.source_rgb.allFinite() || !s.target_rgb.allFinite() || s.target_rgb.minCoeff() <= 0.0f) continue;
    const Eigen::Vector3f ratio = irms.Ratio(s.normal, s.source_sun, s.target_sun, s.sky_view, s.sky_moment,
                                             s.source_indirect, s.target_indirect);
    if (!ratio.allFinite()) continue;
    before += (s.source_rgb - s.target_rgb).cwiseQuotient(s.target_rgb).squaredNorm() / 3.0;
    after += (s.source_rgb.cwiseProduct(ratio) - s.target_rgb).cwiseQuotient(s.target_rgb).squaredNorm() / 3.0;
    ++compared;
  }
  if (compared > 0) {
    summary->overlap_rms_before = std::sqrt(before / compared);
    summary->overlap_rms_after = std::sqrt(after / compared);
  }
  summary->build_s = SecondsSince(start);
  return irms;
}

namespace {

// What every pixel of one relighting reads, prepared once: the per-vertex fractions and sky
// views, the sun disks' directions for the pixels that cast their own sun rays, and the IRMs
// baked into a RatioTable.
struct PixelContext {
  const RayCaster& caster;
  const View& source;
  const std::vector<float>& sun_source;
  const std::vector<float>& sun_target;
  const std::vector<float>& sky_view;    // the source's; empty without sky views
  const std::vector<float>& sky_moment;  // the source's zenith moments; empty without
  // IrmSet::vertex_indirect_*: light from the other surfaces per vertex; empty without.
  const std::vector<Eigen::Vector3f>& indirect_source;
  const std::vector<Eigen::Vector3f>& indirect_target;
  // IrmSet::vertex_radiance_*: what a pixel's own gather reads; empty without.
  const std::vector<Eigen::Vector3f>& radiance_source;
  const std::vector<Eigen::Vector3f>& radiance_target;
  const RelightOptions& options;
  Eigen::Vector3f source_sun_dir, target_sun_dir;  // normalised
  std::vector<Eigen::Vector3f> source_disk, target_disk;
  RatioTable ratios;
};

struct PixelCounts {
  std::int64_t relit = 0, without_ratio = 0, masked = 0, own_sun_rays = 0, own_sky_rays = 0, own_indirect_rays = 0;
  PixelCounts& operator+=(const PixelCounts& o) {
    own_indirect_rays += o.own_indirect_rays;
    relit += o.relit;
    without_ratio += o.without_ratio;
    masked += o.masked;
    own_sun_rays += o.own_sun_rays;
    own_sky_rays += o.own_sky_rays;
    return *this;
  }
};

// What every pixel on one triangle shares: whether it casts its own sun rays (a vertex
// without a fraction, or with exact_shadow_edges a shadow edge across the triangle) or sky rays
// (a vertex without a sky view), and for a flat triangle (three equal vertex normals, as on
// every box, wall and split mesh) its normal and the ratio table's terms for it. Also own sky
// rays, with exact_shadow_edges, where the vertices' sky views span more than
// kSkyViewEdgeSpread.
struct TriangleTerms {
  int triangle = -1;
  // The vertices' fractions and sky views (NaN without sky views), read once per triangle.
  std::array<float, 3> source_sun{}, target_sun{}, sky_view{}, sky_moment{};
  std::array<Eigen::Vector3f, 3> indirect_source{}, indirect_target{};  // zero without
  bool own_source = false, own_target = false, own_sky = false, own_indirect = false;
  bool flat = false;
  Eigen::Vector3f normal = Eigen::Vector3f::Zero();
  const RatioTable::NormalTerms* ratio_terms = nullptr;  // flat: in the chunk's NormalTermsCache
};

// The ratio table's terms for the flat triangles' normals a chunk of rows met last: a scene has
// few distinct flat normals (ground, walls, roofs), each shared by many triangles, while the
// triangles along a row change every few pixels.
class NormalTermsCache {
 public:
  const RatioTable::NormalTerms& Get(const RatioTable& table, const Eigen::Vector3f& normal) {
    for (const Entry& e : entries_) {
      if (e.used && e.normal == normal) return e.terms;
    }
    Entry& e = entries_[next_++ % entries_.size()];
    e = {true, normal, table.Prepare(normal)};
    return e.terms;
  }

 private:
  struct Entry {
    bool used = false;
    Eigen::Vector3f normal = Eigen::Vector3f::Zero();
    RatioTable::NormalTerms terms;
  };
  std::array<Entry, 8> entries_;
  std::size_t next_ = 0;
};

// The vertices disagree about the sun: a shadow edge crosses the triangle.
bool MixedAt(const std::vector<float>& f, const Eigen::Vector3i& tri) {
  const float a = f[static_cast<std::size_t>(tri[0])], b = f[static_cast<std::size_t>(tri[1])],
              c = f[static_cast<std::size_t>(tri[2])];
  return std::max({a, b, c}) - std::min({a, b, c}) > 1e-3f;
}

// The largest difference between a triangle's three vertex values.
float SpreadAt(const std::vector<float>& f, const Eigen::Vector3i& tri) {
  const float a = f[static_cast<std::size_t>(tri[0])], b = f[static_cast<std::size_t>(tri[1])],
              c = f[static_cast<std::size_t>(tri[2])];
  return std::max({a, b, c}) - std::min({a, b, c});
}

bool AnyNaN(const std::vector<float>& f, const Eigen::Vector3i& tri) {
  return std::isnan(f[static_cast<std::size_t>(tri[0])]) || std::isnan(f[static_cast<std::size_t>(tri[1])]) ||
         std::isnan(f[static_cast<std::size_t>(tri[2])]);
}

// RayCaster::Interpolate of one triangle's three values, with the same arithmetic.
float InterpolateAt(const std::array<float, 3>& v, const RayCaster::Hit& hit) {
  return v[0] * (1.0f - hit.u - hit.v) + v[1] * hit.u + v[2] * hit.v;
}

void PrepareTriangle(const PixelContext& c, int triangle, NormalTermsCache& normals, TriangleTerms& t) {
  const TriangleMesh& mesh = c.caster.mesh();
  const Eigen::Vector3i& tri = mesh.triangles[static_cast<std::size_t>(triangle)];
  t.triangle = triangle;
  for (std::size_t k = 0; k < 3; ++k) {
    const auto vertex = static_cast<std::size_t>(tri[static_cast<Eigen::Index>(k)]);
    t.source_sun[k] = c.sun_source[vertex];
    t.target_sun[k] = c.sun_target[vertex];
    t.sky_view[k] = c.sky_view.empty() ? std::numeric_limits<float>::quiet_NaN() : c.sky_view[vertex];
    t.sky_moment[k] = c.sky_moment.empty() ? std::numeric_limits<float>::quiet_NaN() : c.sky_moment[vertex];
    t.indirect_source[k] = c.indirect_source.empty() ? Eigen::Vector3f::Zero() : c.indirect_source[vertex];
    t.indirect_target[k] = c.indirect_target.empty() ? Eigen::Vector3f::Zero() : c.indirect_target[vertex];
  }
  // An interpolated value is NaN exactly when a vertex's is.
  if (AnyNaN(c.sun_source, tri) || AnyNaN(c.sun_target, tri)) {
    t.own_source = t.own_target = true;  // both fractions from the pixel's own rays
  } else {
    t.own_source = c.options.exact_shadow_edges && MixedAt(c.sun_source, tri);
    t.own_target = c.options.exact_shadow_edges && MixedAt(c.sun_target, tri);
  }
  t.own_sky = !c.sky_view.empty() && (AnyNaN(c.sky_view, tri) ||
                                      (c.options.exact_shadow_edges && SpreadAt(c.sky_view, tri) > kSkyViewEdgeSpread));
  if (c.options.exact_shadow_edges && !c.radiance_source.empty()) {
    auto spread = [&](const std::array<Eigen::Vector3f, 3>& v) {
      const float a = v[0].sum(), b = v[1].sum(), d = v[2].sum();
      const float largest = std::max({a, b, d});
      return largest > 0.0f ? (largest - std::min({a, b, d})) / largest : 0.0f;
    };
    t.own_indirect = spread(t.indirect_source) > kIndirectEdgeSpread || spread(t.indirect_target) > kIndirectEdgeSpread;
  }
  const Eigen::Vector3f& n0 = mesh.normals[static_cast<std::size_t>(tri[0])];
  t.flat = n0 == mesh.normals[static_cast<std::size_t>(tri[1])] && n0 == mesh.normals[static_cast<std::size_t>(tri[2])];
  if (t.flat) {
    // The interpolated normal differs from this one by float rounding only.
    t.normal = n0.normalized();
    t.ratio_terms = &normals.Get(c.ratios, t.normal);
  }
}

// The ratio at one camera ray's hit on the triangle of `t`; its sun fractions in *fs, *ft.
Eigen::Vector3f RatioAt(const PixelContext& c, const TriangleTerms& t, const RayCaster::Hit& hit, float* fs, float* ft,
                        PixelCounts& counts) {
  const RayCaster& caster = c.caster;
  const TriangleMesh& mesh = caster.mesh();
  const Eigen::Vector3f normal = t.flat ? t.normal : caster.Interpolate(mesh.normals, hit).normalized();
  *fs = InterpolateAt(t.source_sun, hit);
  *ft = InterpolateAt(t.target_sun, hit);
  if (t.own_source || t.own_target) {
    const Eigen::Vector3f point = caster.Interpolate(mesh.positions, hit);
    if (t.own_source) *fs = SunFractionAt(c.caster, point, normal, c.source_sun_dir, c.source_disk);
    if (t.own_target) *ft = SunFractionAt(c.caster, point, normal, c.target_sun_dir, c.target_disk);
    // The paper's bits: an interpolated fraction beside an own one is rounded too.
    if (!c.options.use_penumbra_fractions) {
      *fs = *fs >= 0.5f ? 1.0f : 0.0f;
      *ft = *ft >= 0.5f ? 1.0f : 0.0f;
    }
    ++counts.own_sun_rays;
  }
  float sky = std::numeric_limits<float>::quiet_NaN(), moment = std::numeric_limits<float>::quiet_NaN();
  if (t.own_sky) {  // a vertex outside the view's neighbourhood, or a sky-view edge: own rays
    const SkyView own = SkyViewMoments(caster, caster.Interpolate(mesh.positions, hit), normal, c.options.sky_samples);
    sky = own.view;
    if (!c.sky_moment.empty()) moment = own.zenith_moment;
    ++counts.own_sky_rays;
  } else if (!c.sky_view.empty()) {
    sky = InterpolateAt(t.sky_view, hit);
    if (!c.sky_moment.empty()) moment = InterpolateAt(t.sky_moment, hit);
  }
  const float w0 = 1.0f - hit.u - hit.v;
  Eigen::Vector3f i_s = t.indirect_source[0] * w0 + t.indirect_source[1] * hit.u + t.indirect_source[2] * hit.v;
  Eigen::Vector3f i_t = t.indirect_target[0] * w0 + t.indirect_target[1] * hit.u + t.indirect_target[2] * hit.v;
  if (t.own_indirect) {  // the light from the neighbours changes too fast across the triangle
    IndirectAt(caster, caster.Interpolate(mesh.positions, hit), normal, c.options.indirect_samples, c.radiance_source,
               c.radiance_target, &i_s, &i_t);
    ++counts.own_indirect_rays;
  }
  return t.flat ? c.ratios.Ratio(*t.ratio_terms, *fs, *ft, sky, moment, i_s, i_t)
                : c.ratios.Ratio(normal, *fs, *ft, sky, moment, i_s, i_t);
}

// One row of the source: every output pixel is written here (no image is filled beforehand).
void RelightRow(const PixelContext& c, int y, std::vector<RayCaster::Hit>& hits, NormalTermsCache& normals,
                RelightResult& result, PixelCounts& chunk_counts) {
  const int width = c.source.image->width();
  c.caster.IntersectCameraRow(c.source.camera, y, 0, width, hits);
  const std::uint8_t* mask = c.source.mask.empty() ? nullptr : c.source.mask.ptr<std::uint8_t>(y);
  const cv::Vec3f* in = c.source.image->pixels.ptr<cv::Vec3f>(y);
  cv::Vec3f* out = result.relit.pixels.ptr<cv::Vec3f>(y);
  std::uint8_t* status = result.status.ptr<std::uint8_t>(y);
  float* fs_row = result.source_sun.ptr<float>(y);
  float* ft_row = result.target_sun.ptr<float>(y);
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  TriangleTerms triangle;  // neighbouring pixels mostly see the same triangle
  // Counted here and added to the chunk's once per row (the chunk's counts are shared
  // through a reference, these stay in registers).
  PixelCounts counts;
  for (int x = 0; x < width; ++x) {
    const RayCaster::Hit& hit = hits[static_cast<std::size_t>(x)];
    out[x] = in[x];
    fs_row[x] = kNaN;
    ft_row[x] = kNaN;
    status[x] = kNoGeometry;
    if (!hit.valid) continue;
    if (mask != nullptr && mask[x] != 0) {
      status[x] = kMasked;
      ++counts.masked;
      continue;
    }
    if (hit.triangle != triangle.triangle) PrepareTriangle(c, hit.triangle, normals, triangle);
    const Eigen::Vector3f ratio = RatioAt(c, triangle, hit, &fs_row[x], &ft_row[x], counts);
    if (!ratio.allFinite()) {
      status[x] = kNoRatio;
      ++counts.without_ratio;
      continue;
    }
    for (int ch = 0; ch < 3; ++ch) out[x][ch] *= ratio[ch];
    status[x] = kRelit;
    ++counts.relit;
  }
  chunk_counts += counts;
}

}  // namespace

RelightResult RelightPixels(const RayCaster& caster, const View& source, const View& target,
                            const ViewGeometry& source_geometry, const ViewGeometry& target_geometry,
                            const IrmSet& irms, const RelightOptions& options, RelightSummary summary) {
  const auto start = std::chrono::steady_clock::now();
  const TriangleMesh& mesh = caster.mesh();
  RELUME_CHECK(source_geometry.sun_fraction.size() == mesh.vertex_count() &&
               target_geometry.sun_fraction.size() == mesh.vertex_count());
  RELUME_CHECK(source_geometry.sky_view.empty() || source_geometry.sky_view.size() == mesh.vertex_count());
  RELUME_CHECK(source_geometry.sky_moment.empty() || source_geometry.sky_moment.size() == mesh.vertex_count());
  RELUME_CHECK(irms.vertex_indirect_source.empty() || (irms.vertex_indirect_source.size() == mesh.vertex_count() &&
                                                       irms.vertex_indirect_target.size() == mesh.vertex_count()));
  RELUME_CHECK(irms.vertex_radiance_source.empty() || (irms.vertex_radiance_source.size() == mesh.vertex_count() &&
                                                       irms.vertex_radiance_target.size() == mesh.vertex_count()));
  const Eigen::Vector3f source_sun_dir = source.sun_dir.normalized(), target_sun_dir = target.sun_dir.normalized();
  const PixelContext context{caster,
                             source,
                             source_geometry.sun_fraction,
                             target_geometry.sun_fraction,
                             source_geometry.sky_view,  // the source's pixels are relit
                             source_geometry.sky_moment,
                             irms.vertex_indirect_source,
                             irms.vertex_indirect_target,
                             irms.vertex_radiance_source,
                             irms.vertex_radiance_target,
                             options,
                             source_sun_dir,
                             target_sun_dir,
                             SunDiskDirections(source_sun_dir, options.sun_angular_radius_rad, options.sun_samples),
                             SunDiskDirections(target_sun_dir, options.sun_angular_radius_rad, options.sun_samples),
                             RatioTable(irms)};
  RelightResult result;
  result.irms = irms;
  const int width = source.image->width(), height = source.image->height();
  // Allocated, not filled: RelightRow writes every pixel once (a clone and NaN fills first
  // would be three more passes over about 0.5 GB at 24 MP).
  result.relit.pixels.create(height, width, CV_32FC3);
  result.relit.unit = source.image->unit;
  result.status.create(height, width, CV_8UC1);
  result.source_sun.create(height, width, CV_32FC1);
  result.target_sun.create(height, width, CV_32FC1);
  // Each chunk of rows has its own hit buffer, normal cache and counts (integers: their sum
  // does not depend on how the rows were split).
  std::mutex total_mutex;
  PixelCounts total;
  ParallelFor(
      0, height,
      [&](std::int64_t y_begin, std::int64_t y_end) {
        std::vector<RayCaster::Hit> hits(static_cast<std::size_t>(width));
        NormalTermsCache normals;
        PixelCounts counts;
        for (std::int64_t y = y_begin; y < y_end; ++y)
          RelightRow(context, static_cast<int>(y), hits, normals, result, counts);
        const std::lock_guard<std::mutex> lock(total_mutex);
        total += counts;
      },
      options.threads);
  summary.pixels_relit = total.relit;
  summary.pixels_without_ratio = total.without_ratio;
  summary.pixels_masked = total.masked;
  summary.pixels_with_own_sun_rays = total.own_sun_rays;
  summary.pixels_with_own_sky_rays = total.own_sky_rays;
  summary.pixels_with_own_indirect_rays = total.own_indirect_rays;
  summary.pixels_without_geometry = static_cast<std::int64_t>(width) * height - summary.pixels_relit -
                                    summary.pixels_without_ratio - summary.pixels_masked;
  summary.relight_s = SecondsSince(start);
  result.summary = summary;
  return result;
}

RelightResult RelightImage(const RayCaster& caster, const View& source, const View& target,
                           const RelightOptions& options) {
  CheckRelightInputs(caster, source, target, options);
  RelightSummary summary;
  const ViewGeometry source_geometry = ComputeViewGeometry(caster, source, options);
  const ViewGeometry target_geometry = ComputeViewGeometry(caster, target, options, /*with_sky_view=*/false);
  summary.preprocess_s = source_geometry.seconds + target_geometry.seconds;
  const IrmSet irms = BuildIrmsFromViews(caster, source, target, source_geometry, target_geometry, options, &summary);
  return RelightPixels(caster, source, target, source_geometry, target_geometry, irms, options, summary);
}

}  // namespace relume::irm
