// SH suites: RGB-D lighting estimation + relighting (processing/sh_pipeline.h, relight.h) on
// random scenes of Lambertian spheres and boxes before a wall.
//
// Scenes (one draw per seed): 2-6 objects (spheres r 4-18 cm, boxes with half extents 3-11 cm
// in random orientations) 0.65-1.35 m from the camera, each with its own albedo (channels
// 0.15-0.85), a wall 0.2-0.6 m behind them. Nothing casts a shadow: the irradiance is the
// light's E(n) at the normal, computed exactly, so the truth is not band-limited to the SH
// order the method fits. Two light families, source and destination drawn independently:
//  - lamps: a distant key lamp (from the camera's side: direction z <= 0.3 in the camera
//    frame, not from below), a fill lamp (0.05-0.4 of the key, from the camera's half space)
//    and a uniform sky over the upper hemisphere (up within 20 deg of the image's up), each
//    with its own colour; E(n) = clamped cosines + pi L (1 + n.up) / 2;
//  - smooth: a sky gradient over a darker ground and one or two broad lobes (DrawSmoothLighting);
//    E(n) by direct summation of the map, tabulated over normals.
//
// Method: what the sh pipeline runs. ShLightEstimator::EstimateKnownAlbedo (the denoise
// decision on the stream's first frame: exact depth is not filtered, noisy depth is; filters,
// normals, sample points, known-albedo SH fit; primed on a previous frame as in a stream), then
// RelightSh to the destination light estimated the same way from a frame of the scene under
// it (the pipeline's default --target-light FRAME).
// Bounces (sh-smooth-light-bounces): the smooth-light scenes, the same draws, with the light the
// objects and the wall send each other added to both renders (3 diffuse bounces, path traced:
// bench/primitive_bounces.h). The direct light stays unoccluded, as in the other suites (cast
// shadows are another failure of the SH model); what this adds is near-field light, which a
// distant SH light cannot represent exactly.
// Floor: the same fits and relighting given the TRUE normals at the same sample points: what
// order-2 SH lighting can do on this scene at best; the gap to the method is what depth noise
// and normal estimation cost. The notes split the gap (the method's light with the true
// normals; the floor's light with the method's normals) and count the pixels whose normal is
// more than 3 deg off.
// Error: signal-relative RMS of the relit image against the truth under the destination
// light, over the pixels the method relit (processing/metrics.h; absolute scale, as the sh
// pipeline's comparison with the truth).
// Each suite also reports, on the same scenes, renders, samples and normals:
//  - "-nonneg": the non-negative directional light (processing/nonneg_light.h) fitted and
//    relit in place of the SH light; floor: the same fit from the true normals;
//  - "-unknown-albedo": the sh pipeline's default fit (k-means segments and the alternating SH
//    fit in the destination frame, the source fitted with its segments' albedos); floor: the
//    known-albedo method above (what knowing the albedo gives).
#include <Eigen/Geometry>
#include <chrono>
#include <cmath>
#include <numbers>
#include <sstream>

#include "bench/primitive_bounces.h"
#include "bench/suites.h"
#include "processing/metrics.h"
#include "processing/nonneg_light.h"
#include "processing/relight.h"
#include "processing/sh.h"
#include "processing/sh_fit.h"
#include "processing/sh_pipeline.h"
#include "processing/testing/synthetic_scene.h"

namespace relume::bench {
namespace {

namespace pt = processing::testing;

struct Lamp {
  Eigen::Vector3d direction;   // unit, camera frame, from the surface toward the lamp
  Eigen::Vector3d irradiance;  // RGB, on a plane facing the lamp
};

// A distant light: either lamps and a uniform hemisphere sky (exact irradiance: clamped
// cosines), or a smooth environment map (irradiance tabulated over normals by direct
// summation of the map).
struct Lighting {
  // Lamps + sky.
  std::vector<Lamp> lamps;
  Eigen::Vector3d up = Eigen::Vector3d(0, -1, 0);          // unit, camera frame
  Eigen::Vector3d sky_radiance = Eigen::Vector3d::Zero();  // RGB, uniform over the hemisphere around `up`
  // Smooth map (empty for lamps + sky): lat-long, +z up, and E(n) per normal on a lat-long grid.
  RadianceImage map;
  Eigen::Matrix3d camera_from_map = Eigen::Matrix3d::Identity();
  int table_width = 0, table_height = 0;
  std::vector<Eigen::Vector3d> table;

  Eigen::Vector3d Irradiance(const Eigen::Vector3d& n) const {
    if (!table.empty()) return TableIrradiance(camera_from_map.transpose() * n);
    Eigen::Vector3d e = std::numbers::pi * sky_radiance * 0.5 * (1.0 + n.dot(up));
    for (const Lamp& l : lamps) e += l.irradiance * std::max(0.0, n.dot(l.direction));
    return e;
  }
  // The exact SH projection. Lamps and sky by Funk-Hecke: a lamp is I Y_k(l); the hemisphere
  // sky is L lambda_l Y_k(up) with lambda = (2 pi, pi, 0) per band. A map by summation.
  processing::ShRgb Sh() const {
    if (!table.empty()) return processing::ProjectEnvironmentMap(map, camera_from_map);
    processing::ShRgb sh = processing::ShRgb::Zero();
    for (const Lamp& l : lamps) sh += processing::ShBasis(l.direction) * l.irradiance.transpose();
    processing::ShVector sky = processing::ShBasis(up);
    for (int k = 0; k < processing::kShCount; ++k) {
      const int band = k == 0 ? 0 : k < 4 ? 1 : 2;
      sky(k) *= band == 0 ? 2.0 * std::numbers::pi : band == 1 ? std::numbers::pi : 0.0;
    }
    return sh + sky * sky_radiance.transpose();
  }

  // E(n) for every cell centre of a table_width x table_height lat-long grid of normals (map
  // frame), summed over every map pixel as processing::IntegrateIrradiance does.
  void Tabulate(int width, int height) {
    std::vector<Eigen::Vector3d> directions, radiance_solid_angle;
    for (int v = 0; v < map.height(); ++v) {
      const double solid_angle = processing::LatLongPixelSolidAngle(v, map.width(), map.height());
      for (int u = 0; u < map.width(); ++u) {
        const cv::Vec3f l = map.pixels.at<cv::Vec3f>(v, u);
        directions.push_back(processing::LatLongDirection(u + 0.5, v + 0.5, map.width(), map.height()));
        radiance_solid_angle.push_back(Eigen::Vector3d(l[0], l[1], l[2]) * solid_angle);
      }
    }
    table_width = width;
    table_height = height;
    table.assign(static_cast<std::size_t>(width) * height, Eigen::Vector3d::Zero());
    for (int v = 0; v < height; ++v) {
      for (int u = 0; u < width; ++u) {
        const Eigen::Vector3d n = processing::LatLongDirection(u + 0.5, v + 0.5, width, height);
        Eigen::Vector3d& e = table[static_cast<std::size_t>(v) * width + u];
        for (std::size_t i = 0; i < directions.size(); ++i) {
          const double c = directions[i].dot(n);
          if (c > 0.0) e += radiance_solid_angle[i] * c;
        }
      }
    }
  }
  // Bilinear between cell centres (wrapping in azimuth, clamped at the poles).
  Eigen::Vector3d TableIrradiance(const Eigen::Vector3d& n_in_map) const {
    const double theta = std::acos(std::clamp(n_in_map.z(), -1.0, 1.0));
    double phi = std::atan2(n_in_map.y(), n_in_map.x());
    if (phi < 0.0) phi += 2.0 * std::numbers::pi;
    const double x = phi / (2.0 * std::numbers::pi) * table_width - 0.5;
    const double y = std::clamp(theta / std::numbers::pi * table_height - 0.5, 0.0, table_height - 1.0);
    const int x0 = static_cast<int>(std::floor(x)), y0 = std::min(static_cast<int>(y), table_height - 2);
    const double fx = x - x0, fy = y - y0;
    auto at = [&](int u, int v) -> const Eigen::Vector3d& {
      u = ((u % table_width) + table_width) % table_width;
      return table[static_cast<std::size_t>(v) * table_width + u];
    };
    return (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) +
           fy * ((1 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
  }
};

// The rotation taking unit vector a to unit vector b (Rodrigues; a and b not opposite).
Eigen::Matrix3d RotationTaking(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector3d axis = a.cross(b);
  const double s = axis.norm(), c = a.dot(b);
  if (s < 1e-12) return Eigen::Matrix3d::Identity();
  Eigen::Matrix3d k;
  k << 0, -axis.z(), axis.y(), axis.z(), 0, -axis.x(), -axis.y(), axis.x(), 0;
  k /= s;
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  r += s * k + (1.0 - c) * k * k;
  return r;
}

Eigen::Vector3d RandomUnit(SceneRandom& random) {
  for (;;) {
    const Eigen::Vector3d v(random.Gaussian(), random.Gaussian(), random.Gaussian());
    if (v.norm() > 1e-6) return v.normalized();
  }
}

Eigen::Vector3d RandomColour(SceneRandom& random, double lo, double hi) {
  return {random.Uniform(lo, hi), random.Uniform(lo, hi), random.Uniform(lo, hi)};
}

Lighting DrawLighting(SceneRandom& random, const Eigen::Vector3d& up) {
  Lighting light;
  light.up = up;
  Eigen::Vector3d key;
  do key = RandomUnit(random);
  while (key.z() > 0.3 || key.dot(up) < -0.2);
  const double key_level = random.Uniform(2.0, 6.0);
  light.lamps.push_back({key, key_level * RandomColour(random, 0.8, 1.2)});
  Eigen::Vector3d fill;
  do fill = RandomUnit(random);
  while (fill.z() > 0.0);
  light.lamps.push_back({fill, key_level * random.Uniform(0.05, 0.4) * RandomColour(random, 0.7, 1.3)});
  light.sky_radiance = key_level * random.Uniform(0.01, 0.08) * RandomColour(random, 0.6, 1.4);
  return light;
}

// A smooth light: a sky gradient over a darker ground and one or two broad lobes (area lights
// or an overcast sun: exp(s (cos - 1)) with s log-uniform in [1, 16], i.e. lobes 80 to 20 deg
// wide), rotated at random about the vertical.
Lighting DrawSmoothLighting(SceneRandom& random, const Eigen::Matrix3d& camera_from_map) {
  Lighting light;
  light.camera_from_map = camera_from_map;
  const int width = 64, height = 32;
  light.map = MakeRadianceImage(width, height);
  const Eigen::Vector3d zenith = RandomColour(random, 0.2, 0.9), horizon = RandomColour(random, 0.4, 1.0);
  const Eigen::Vector3d ground = RandomColour(random, 0.05, 0.3);
  struct Lobe {
    Eigen::Vector3d direction, radiance;
    double sharpness;
  };
  std::vector<Lobe> lobes;
  const int count = random.Int(1, 2);
  for (int i = 0; i < count; ++i) {
    const double elevation = random.Uniform(5.0, 80.0) * std::numbers::pi / 180.0;
    const double azimuth = random.Uniform(0.0, 2.0 * std::numbers::pi);
    const double sharpness = std::exp(random.Uniform(std::log(1.0), std::log(16.0)));
    // Peak radiance so that the lobe brings 1-6x the sky's irradiance (a lobe's solid angle is
    // about 2 pi / s).
    const double peak = random.Uniform(1.0, 6.0) * sharpness / 2.0;
    lobes.push_back(
        {{std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth), std::sin(elevation)},
         peak * RandomColour(random, 0.8, 1.2),
         sharpness});
  }
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const Eigen::Vector3d w = processing::LatLongDirection(u + 0.5, v + 0.5, width, height);
      Eigen::Vector3d l = w.z() >= 0.0 ? zenith + (horizon - zenith) * std::pow(1.0 - w.z(), 3.0) : ground;
      for (const Lobe& lobe : lobes) l += lobe.radiance * std::exp(lobe.sharpness * (w.dot(lobe.direction) - 1.0));
      light.map.pixels.at<cv::Vec3f>(v, u) = cv::Vec3f(l.x(), l.y(), l.z());
    }
  }
  light.Tabulate(128, 64);
  light.up = camera_from_map.col(2);
  return light;
}

struct ShSceneDraw {
  pt::PrimitiveScene scene;
  Lighting source, destination;
  std::string description;
};

enum class LightFamily { kLamps, kSmooth };

ShSceneDraw DrawScene(std::uint64_t seed, bool quick, LightFamily family) {
  SceneRandom random(seed);
  ShSceneDraw d;
  const int width = quick ? 160 : 320, height = quick ? 120 : 240;
  d.scene.intrinsics = PinholeIntrinsics::FromHorizontalFov(width, height, 60.0 * std::numbers::pi / 180.0);
  const int count = random.Int(2, 6);
  int spheres = 0;
  double nearest = 1e9, farthest = 0.0;
  for (int i = 0; i < count; ++i) {
    pt::Primitive o;
    const double depth = random.Uniform(0.65, 1.35);
    // Centre inside the middle 70 % of the image.
    const Eigen::Vector3d ray =
        d.scene.intrinsics.Unproject({random.Uniform(0.15, 0.85) * width, random.Uniform(0.15, 0.85) * height});
    o.centre = ray * depth;
    if (random.Chance(0.5)) {
      o.kind = pt::Primitive::Kind::kSphere;
      o.radius = random.Uniform(0.04, 0.18);
      ++spheres;
    } else {
      o.kind = pt::Primitive::Kind::kBox;
      const Eigen::Quaterniond q(random.Gaussian(), random.Gaussian(), random.Gaussian(), random.Gaussian());
      o.camera_from_box = q.normalized().toRotationMatrix();
      o.half_extents = {random.Uniform(0.03, 0.11), random.Uniform(0.03, 0.11), random.Uniform(0.03, 0.11)};
    }
    o.albedo = RandomColour(random, 0.15, 0.85);
    d.scene.objects.push_back(o);
    nearest = std::min(nearest, depth);
    farthest = std::max(farthest, depth);
  }
  d.scene.wall_depth_m = farthest + random.Uniform(0.2, 0.6);
  d.scene.wall_albedo = Eigen::Vector3d::Constant(random.Uniform(0.3, 0.7));
  // The image's up is -y; the sky's up within 20 degrees of it.
  const Eigen::Vector3d axis = RandomUnit(random);
  const Eigen::Vector3d up =
      Eigen::AngleAxisd(random.Uniform(0.0, 20.0) * std::numbers::pi / 180.0, axis) * Eigen::Vector3d(0, -1, 0);
  if (family == LightFamily::kLamps) {
    d.source = DrawLighting(random, up);
    d.destination = DrawLighting(random, up);
  } else {
    // The map's +z along `up`, turned about it at random (processing::testing::CameraFromMap
    // is the untilted frame).
    const Eigen::Matrix3d tilt_from_map = RotationTaking(Eigen::Vector3d(0, -1, 0), up) * pt::CameraFromMap();
    auto frame = [&] {
      const double turn = random.Uniform(0.0, 2.0 * std::numbers::pi);
      Eigen::Matrix3d about_up = Eigen::Matrix3d::Identity();
      about_up.topLeftCorner<2, 2>() << std::cos(turn), -std::sin(turn), std::sin(turn), std::cos(turn);
      const Eigen::Matrix3d camera_from_map = tilt_from_map * about_up;
      return camera_from_map;
    };
    d.source = DrawSmoothLighting(random, frame());
    d.destination = DrawSmoothLighting(random, frame());
  }
  std::ostringstream s;
  s.precision(2);
  s << std::fixed << spheres << " sphere(s) + " << count - spheres << " box(es) at " << nearest << "-" << farthest
    << " m";
  if (family == LightFamily::kLamps) {
    auto elevation = [&](const Lighting& l) {
      return std::asin(l.lamps[0].direction.dot(up)) * 180.0 / std::numbers::pi;
    };
    s << "; key lamp elevation " << elevation(d.source) << " -> " << elevation(d.destination) << " deg";
  }
  d.description = s.str();
  return d;
}

// The relit image's error against the destination truth over the pixels relit.
double RelitError(const processing::RelightResult& relit, const pt::SyntheticFrame& truth) {
  return metrics::SignalRelativeRms(relit.relit.pixels, truth.radiance.pixels, relit.valid, metrics::Scale::kAbsolute)
      .relative_rms;
}

// The floor's fit: known albedo, true normals, the method's sample points.
processing::ShFitResult FitAtTrueNormals(const pt::SyntheticFrame& frame, const std::vector<cv::Point>& samples) {
  return processing::FitShKnownAlbedo(
      processing::GatherObservations(frame.radiance, frame.normal_in_camera, frame.albedo, {}, samples));
}

// Where the method's normals are more than 3 degrees off among the relit pixels, and the
// relit error on the other pixels: the part of the gap to the floor that edges and creases
// (where a depth map cannot give one normal) account for.
struct NormalDiagnosis {
  double bad_fraction = 0.0, mean_angle_deg = 0.0, error_on_good = NAN;
};
NormalDiagnosis DiagnoseNormals(const processing::RelightResult& relit, const cv::Mat& estimated,
                                const pt::SyntheticFrame& src, const pt::SyntheticFrame& dst) {
  NormalDiagnosis out;
  cv::Mat good = relit.valid.clone();
  int bad = 0, count = 0;
  for (int y = 0; y < good.rows; ++y) {
    for (int x = 0; x < good.cols; ++x) {
      if (!good.at<unsigned char>(y, x)) continue;
      const cv::Vec3f a = estimated.at<cv::Vec3f>(y, x), b = src.normal_in_camera.at<cv::Vec3f>(y, x);
      const double angle = std::acos(std::clamp(static_cast<double>(a.dot(b)), -1.0, 1.0)) * 180.0 / std::numbers::pi;
      ++count;
      out.mean_angle_deg += angle;
      if (angle > 3.0) {
        good.at<unsigned char>(y, x) = 0;
        ++bad;
      }
    }
  }
  if (count == 0) return out;
  out.bad_fraction = static_cast<double>(bad) / count;
  out.mean_angle_deg /= count;
  out.error_on_good =
      metrics::SignalRelativeRms(relit.relit.pixels, dst.radiance.pixels, good, metrics::Scale::kAbsolute).relative_rms;
  return out;
}

// One scene's results: the SH method and, on the same renders and normals, the non-negative
// directional light (processing/nonneg_light.h) in place of the SH fit, and both with the
// albedo unknown.
struct ShSceneResults {
  SceneResult sh, nonneg, unknown, nonneg_unknown;
};

// The non-negative light's method and floor: fitted where the SH fits were (the method's
// normals at the method's samples; the true normals at the same samples), relit as the SH
// relighting is (the method with the pipeline's ratio filter, the floor each pixel by its own).
SceneResult RunNonNegative(const SceneResult& base, const pt::SyntheticFrame& src, const pt::SyntheticFrame& dst,
                           const processing::ShFrameEstimate& estimate, const processing::ShFrameEstimate& target,
                           const processing::RelightOptions& relight, const processing::RelightOptions& per_pixel) {
  SceneResult r;
  r.seed = base.seed;
  r.description = base.description;
  const auto start = std::chrono::steady_clock::now();
  const processing::NonNegativeLightResult fit_src = processing::FitNonNegativeLight(processing::GatherObservations(
      src.radiance, estimate.normals.normal_in_camera, src.albedo, {}, estimate.samples));
  const processing::NonNegativeLightResult fit_dst = processing::FitNonNegativeLight(
      processing::GatherObservations(dst.radiance, target.normals.normal_in_camera, dst.albedo, {}, target.samples));
  if (!fit_src.summary.usable || !fit_dst.summary.usable) {
    r.notes = "the non-negative fit failed: " + (fit_src.summary.usable ? fit_dst : fit_src).summary.message;
    return r;
  }
  const processing::RelightResult relit = processing::RelightNonNegative(
      src.radiance, estimate.normals.normal_in_camera, src.object_mask, fit_src.light, fit_dst.light, relight);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  r.method = RelitError(relit, dst);
  const processing::NonNegativeLightResult floor_src = processing::FitNonNegativeLight(
      processing::GatherObservations(src.radiance, src.normal_in_camera, src.albedo, {}, estimate.samples));
  const processing::NonNegativeLightResult floor_dst = processing::FitNonNegativeLight(
      processing::GatherObservations(dst.radiance, dst.normal_in_camera, dst.albedo, {}, target.samples));
  double method_light = NAN;
  if (floor_src.summary.usable && floor_dst.summary.usable) {
    r.floor = RelitError(processing::RelightNonNegative(src.radiance, src.normal_in_camera, src.object_mask,
                                                        floor_src.light, floor_dst.light, per_pixel),
                         dst);
    method_light = RelitError(processing::RelightNonNegative(src.radiance, src.normal_in_camera, src.object_mask,
                                                             fit_src.light, fit_dst.light, per_pixel),
                              dst);
  }
  std::ostringstream notes;
  notes.precision(3);
  notes << "method's light + true normals " << method_light << "; active directions "
        << fit_src.summary.active_direction_count << "/" << fit_dst.summary.active_direction_count << ", fit residual "
        << fit_src.summary.relative_rms_residual << "/" << fit_dst.summary.relative_rms_residual << ", relit "
        << relit.summary.relit_pixel_count << " of " << relit.summary.requested_pixel_count << " px; SH (same scene) "
        << base.method << ", its floor " << base.floor;
  r.notes = notes.str();
  return r;
}

// The albedo unknown, as the sh pipeline fits it by default: k-means segments and the
// alternating SH fit of the destination frame (FitShFrameUnknownAlbedo, the pipeline's defaults),
// and the source fitted with the destination's segments and albedos (FitShFrameSharedAlbedo),
// relit as the method is. The notes give the error when each frame is fitted on its own (the
// pipeline's shared_albedo=false). Floor: the known-albedo method on the same normals (`known`).
// Into `sh`, and into `nonneg` the same with the non-negative light (light_model=nonnegative:
// FitNonNegativeLightSegments in the destination, FitNonNegativeLightKnownSegments with its
// refined albedos in the source; floor: the known-albedo non-negative method `known_nonneg`).
void RunUnknownAlbedo(const SceneResult& known, const SceneResult& known_nonneg, const pt::SyntheticFrame& src,
                      const pt::SyntheticFrame& dst, const processing::ShFrameEstimate& estimate,
                      const processing::ShFrameEstimate& target, const processing::RelightOptions& relight,
                      SceneResult* sh, SceneResult* nonneg) {
  for (SceneResult* r : {sh, nonneg}) {
    r->seed = known.seed;
    r->description = known.description;
  }
  sh->floor = known.method;
  nonneg->floor = known_nonneg.method;
  const auto start = std::chrono::steady_clock::now();
  processing::SamplePointSelector src_samples, dst_samples, own_samples;
  const processing::ShFrameFit fit_dst = processing::FitShFrameUnknownAlbedo(
      dst.radiance, target.normals.normal_in_camera, dst.object_mask & target.normals.valid, {}, {}, dst_samples);
  const cv::Mat src_allowed = src.object_mask & estimate.normals.valid;
  const processing::ShFrameFit fit_src =
      fit_dst.summary.usable
          ? processing::FitShFrameSharedAlbedo(src.radiance, estimate.normals.normal_in_camera, src_allowed, fit_dst,
                                               src_allowed, {}, {}, src_samples)
          : processing::ShFrameFit{};
  if (!fit_dst.summary.usable || !fit_src.summary.usable) {
    sh->notes = nonneg->notes =
        "the unknown-albedo SH fit failed: " + (fit_dst.summary.usable ? fit_src : fit_dst).summary.message;
    return;
  }
  sh->method = RelitError(processing::RelightSh(src.radiance, estimate.normals.normal_in_camera, src.object_mask,
                                                fit_src.light, fit_dst.light, relight),
                          dst);
  sh->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const processing::ShFrameFit own = processing::FitShFrameUnknownAlbedo(
      src.radiance, estimate.normals.normal_in_camera, src_allowed, {}, {}, own_samples);
  std::ostringstream notes;
  notes.precision(3);
  notes << fit_dst.segmentation.segment_count() << " segments, albedo-light condition "
        << fit_dst.summary.albedo_light_condition_number << "; each frame on its own: ";
  if (own.summary.usable) {
    notes << RelitError(processing::RelightSh(src.radiance, estimate.normals.normal_in_camera, src.object_mask,
                                              own.light, fit_dst.light, relight),
                        dst);
  } else {
    notes << "the fit failed (" << own.summary.message << ")";
  }
  sh->notes = notes.str();

  const auto nonneg_start = std::chrono::steady_clock::now();
  const processing::NonNegativeSegmentFitResult light_dst = processing::FitNonNegativeLightSegments(
      processing::GatherObservations(dst.radiance, target.normals.normal_in_camera, {}, fit_dst.segmentation.labels,
                                     fit_dst.samples),
      fit_dst.segment_albedo, fit_dst.reference_segment, 5, {});
  const processing::NonNegativeLightResult light_src = processing::FitNonNegativeLightKnownSegments(
      processing::GatherObservations(src.radiance, estimate.normals.normal_in_camera, {}, fit_src.segmentation.labels,
                                     fit_src.samples),
      light_dst.segment_albedo, {});
  if (!light_dst.fit.summary.usable || !light_src.summary.usable) {
    nonneg->notes = "the non-negative fit failed: " +
                    (light_dst.fit.summary.usable ? light_src.summary : light_dst.fit.summary).message;
    return;
  }
  nonneg->method =
      RelitError(processing::RelightNonNegative(src.radiance, estimate.normals.normal_in_camera, src.object_mask,
                                                light_src.light, light_dst.fit.light, relight),
                 dst);
  nonneg->seconds =
      sh->seconds + std::chrono::duration<double>(std::chrono::steady_clock::now() - nonneg_start).count();
  nonneg->notes = "on the unknown-albedo SH fit's segments and samples, 5 light / albedo alternations";
}

ShSceneResults RunShScene(std::uint64_t seed, bool quick, bool kinect_noise, LightFamily family, bool bounces) {
  const ShSceneDraw d = DrawScene(seed, quick, family);
  const pt::IrradianceFunction source_light = [&](const Eigen::Vector3d& n) { return d.source.Irradiance(n); };
  const pt::IrradianceFunction destination_light = [&](const Eigen::Vector3d& n) {
    return d.destination.Irradiance(n);
  };
  pt::SyntheticFrame src = pt::RenderPrimitives(d.scene, source_light);
  pt::SyntheticFrame dst = pt::RenderPrimitives(d.scene, destination_light);
  // The bounces suite: the light the objects and the wall send each other, on both renders
  // (the photographs and the truth alike), seeded per scene.
  std::ostringstream bounce_notes;
  if (bounces) {
    PrimitiveBouncesOptions options;
    options.bounces = kSuiteBounces;
    options.seed = seed ^ 0xb0;
    const PrimitiveBouncesSummary a = AddPrimitiveInterreflection(d.scene, source_light, options, &src);
    options.seed = seed ^ 0xb1;
    const PrimitiveBouncesSummary b = AddPrimitiveInterreflection(d.scene, destination_light, options, &dst);
    bounce_notes.precision(3);
    bounce_notes << "; indirect share of the objects' irradiance " << 100.0 * a.indirect_share_mean << " / "
                 << 100.0 * b.indirect_share_mean << " % (source / destination, " << options.bounces << " bounces, "
                 << options.paths << " paths per pixel)";
  }
  // Four depth frames of the same view: the primers of the two streams, then the two measured.
  auto noisy = [&](std::uint64_t salt) {
    return kinect_noise ? pt::AddKinectDepthNoise(src.depth_m, seed ^ salt) : src.depth_m;
  };
  const cv::Mat src_primer = noisy(0x51), dst_primer = noisy(0x52);
  const PinholeIntrinsics& k = d.scene.intrinsics;

  ShSceneResults results;
  SceneResult& r = results.sh;
  r.seed = seed;
  r.description = d.description;
  // As the sh pipeline by default: the destination light is the estimate of another frame of
  // the stream, the scene under the destination light (--target-light FRAME).
  // The estimator's defaults: each stream decides on its first frame (the primer) whether
  // to filter depth, by the rule the sh pipeline applies (noise-free depth is not filtered).
  processing::ShLightEstimator src_estimator, dst_estimator;
  src_estimator.EstimateKnownAlbedo(src.radiance, src_primer, k, src.object_mask, src.albedo);
  dst_estimator.EstimateKnownAlbedo(dst.radiance, dst_primer, k, dst.object_mask, dst.albedo);
  const auto start = std::chrono::steady_clock::now();
  const processing::ShFrameEstimate estimate =
      src_estimator.EstimateKnownAlbedo(src.radiance, noisy(0xa3), k, src.object_mask, src.albedo);
  const processing::ShFrameEstimate target =
      dst_estimator.EstimateKnownAlbedo(dst.radiance, noisy(0xa4), k, dst.object_mask, dst.albedo);
  if (!estimate.summary.usable || !target.summary.usable) {
    r.notes = "the SH fit failed: " + (estimate.summary.usable ? target : estimate).summary.message;
    results.nonneg = results.unknown = results.nonneg_unknown = r;
    return results;
  }
  processing::RelightOptions relight;  // as the sh pipeline relights the method's normals
  relight.normals_from_noisy_depth = estimate.depth_filtered;
  const processing::RelightResult relit = processing::RelightSh(src.radiance, estimate.normals.normal_in_camera,
                                                                src.object_mask, estimate.light, target.light, relight);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  r.method = RelitError(relit, dst);

  // The floor: the same fits and relighting with the true normals at the same samples, each
  // pixel by its own ratio (true normals have no error for the ratio filter to average).
  processing::RelightOptions per_pixel;
  per_pixel.ratio_radius_px = 0;
  const processing::ShFitResult floor_src = FitAtTrueNormals(src, estimate.samples);
  const processing::ShFitResult floor_dst = FitAtTrueNormals(dst, target.samples);
  // Where the gap comes from: the method's light with the true normals, the floor's light
  // with the method's normals.
  double projected = NAN, method_light = NAN, method_normals = NAN;
  if (floor_src.summary.usable && floor_dst.summary.usable) {
    r.floor = RelitError(processing::RelightSh(src.radiance, src.normal_in_camera, src.object_mask, floor_src.light,
                                               floor_dst.light, per_pixel),
                         dst);
    // For the record: the destination as the exact SH projection of its light instead of a fit.
    projected = RelitError(processing::RelightSh(src.radiance, src.normal_in_camera, src.object_mask, floor_src.light,
                                                 d.destination.Sh(), per_pixel),
                           dst);
    method_light = RelitError(processing::RelightSh(src.radiance, src.normal_in_camera, src.object_mask, estimate.light,
                                                    target.light, per_pixel),
                              dst);
    method_normals = RelitError(processing::RelightSh(src.radiance, estimate.normals.normal_in_camera, src.object_mask,
                                                      floor_src.light, floor_dst.light, relight),
                                dst);
  }
  const NormalDiagnosis normals = DiagnoseNormals(relit, estimate.normals.normal_in_camera, src, dst);
  std::ostringstream notes;
  notes.precision(3);
  notes << "method's light + true normals " << method_light << ", floor's light + method's normals " << method_normals
        << "; normals > 3 deg off at " << 100.0 * normals.bad_fraction << " % of relit px (mean "
        << normals.mean_angle_deg << " deg), error on the others " << normals.error_on_good << "; order "
        << estimate.summary.order_used << "/" << target.summary.order_used << ", fit residual "
        << estimate.summary.relative_rms_residual << "/" << target.summary.relative_rms_residual << ", relit "
        << relit.summary.relit_pixel_count << " of " << relit.summary.requested_pixel_count
        << " px; floor with the projected destination light " << projected << bounce_notes.str();
  r.notes = notes.str();
  results.nonneg = RunNonNegative(r, src, dst, estimate, target, relight, per_pixel);
  results.nonneg.notes += bounce_notes.str();
  RunUnknownAlbedo(r, results.nonneg, src, dst, estimate, target, relight, &results.unknown, &results.nonneg_unknown);
  results.unknown.notes += bounce_notes.str();
  results.nonneg_unknown.notes += bounce_notes.str();
  return results;
}

// The SH suite and, on the same scenes, the non-negative light's (suite name + "-nonneg") and
// the unknown-albedo fit's (+ "-unknown-albedo").
std::vector<SuiteResult> RunShSuite(const SuiteOptions& options, bool kinect_noise, LightFamily family,
                                    bool bounces = false) {
  SuiteResult result;
  result.suite = family == LightFamily::kSmooth ? "sh-smooth-light"
                 : kinect_noise                 ? "sh-kinect-noise"
                                                : "sh-ideal-depth";
  if (bounces) result.suite += "-bounces";
  result.metric = "relit signal-relative RMS";
  if (bounces) result.metric += "; rendered with " + std::to_string(kSuiteBounces) + " diffuse bounces";
  const std::string depth = kinect_noise ? "Kinect-like depth noise" : "exact depth";
  result.method = depth + " -> denoise decision -> normals -> known-albedo SH fit (order 2) -> relight";
  result.floor = "true normals at the same samples";
  result.goal_median = kinect_noise ? 0.04 : 0.02;
  result.goal_p90 = kinect_noise ? 0.06 : 0.03;
  SuiteResult nonneg = result;
  nonneg.suite += "-nonneg";
  nonneg.method = depth + " -> denoise decision -> normals -> known-albedo non-negative directional light (" +
                  std::to_string(processing::NonNegativeLightOptions{}.direction_count) + " directions) -> relight";
  SuiteResult unknown = result;
  unknown.suite += "-unknown-albedo";
  unknown.method = depth +
                   " -> denoise decision -> normals -> k-means segments -> unknown-albedo SH fit (order 2) of " +
                   "the destination, the source with its segments' albedos (the sh pipeline's default) -> relight";
  unknown.floor = "the known-albedo method (the albedo given)";
  SuiteResult nonneg_unknown = nonneg;
  nonneg_unknown.suite += "-unknown-albedo";
  nonneg_unknown.method = depth +
                          " -> denoise decision -> normals -> k-means segments -> unknown-albedo SH fit of the "
                          "destination, its segment albedos refined by the non-negative light, the source with "
                          "them (the sh pipeline's light_model=nonnegative) -> relight";
  nonneg_unknown.floor = "the known-albedo non-negative method (the albedo given)";
  for (int i = 0; i < options.SceneCount(); ++i) {
    ShSceneResults scene = RunShScene(options.SeedOf(i), options.quick, kinect_noise, family, bounces);
    result.scenes.push_back(std::move(scene.sh));
    nonneg.scenes.push_back(std::move(scene.nonneg));
    unknown.scenes.push_back(std::move(scene.unknown));
    nonneg_unknown.scenes.push_back(std::move(scene.nonneg_unknown));
  }
  return {result, nonneg, unknown, nonneg_unknown};
}

}  // namespace

std::vector<SuiteResult> RunShIdealDepthSuite(const SuiteOptions& options) {
  return RunShSuite(options, false, LightFamily::kLamps);
}

std::vector<SuiteResult> RunShKinectNoiseSuite(const SuiteOptions& options) {
  return RunShSuite(options, true, LightFamily::kLamps);
}

std::vector<SuiteResult> RunShSmoothLightSuite(const SuiteOptions& options) {
  return RunShSuite(options, false, LightFamily::kSmooth);
}

std::vector<SuiteResult> RunShSmoothLightBouncesSuite(const SuiteOptions& options) {
  return RunShSuite(options, false, LightFamily::kSmooth, true);
}

}  // namespace relume::bench
