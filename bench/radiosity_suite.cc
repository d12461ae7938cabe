// Radiosity suite: iterative reflectance estimation (processing/radiosity/reflectance.h,
// Loscos et al. with radiosity for the indirect light) on random furnished rooms.
//
// Scene family (one draw per seed): a room 3-6 x 2.5-5 x 2.4-3.2 m (floor, ceiling, walls),
// 1-3 boxes standing on the floor (tables, cabinets: 0.4-1.6 m wide, 0.3-1.8 m high) and
// sometimes a raised slab on legs (a desk: its floor is lit only indirectly). Every surface
// group has its own material, a grey level of 0.1-0.9 tinted per channel by 0.8-1.2 (at most
// 0.92). 2-5 photographs, each with one isotropic point lamp at a random place 0.5 m or more
// inside the room, and a camera in an upper corner. The photographs are a converged strict
// radiosity solution of the same patches (as processing/radiosity/test_room.h renders) with
// 1 % Gaussian camera noise per patch and channel.
//
// Method: EstimateReflectance with its defaults (indirect light from the observed radiosity,
// iterated until the albedo settles). Floor: the same combination of the same photographs,
// with the method's own per-image weights, given the TRUE indirect irradiance of each patch
// in each photograph (from the rendered solution): what the photographs' noise and the
// weighting leave when nothing about the indirect light has to be estimated.
// Error: per material, |mean albedo over its estimated patches - true albedo|, the mean over
// channels (the error of the mean, issue 20). One SceneResult per material, so the suite's
// median and p90 are over materials of all rooms.
//
// Chart variant (radiosity-rooms-chart, issue 19: albedo in absolute units from an EV-only
// camera): the same rooms with a reference chart on a wall the camera faces (six 15 cm grey
// patches of known albedo 0.03-0.90, the ColorChecker's neutral row, 5 mm off the wall), and
// photographs in unknown units: bracket 0 divided by a scale drawn log-uniformly in [0.05, 20],
// the others also by their own factor in [0.5, 2] (fit_image_scales finds those). Method: the
// absolute scale from the chart (reference_scale.h, its defaults) and the reflectance estimate
// at that scale. Floor: the same estimate at the true scale. Error: as above, over the room's
// materials (the chart's are the input, not a result); the scale's own error is in the notes.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <sstream>

#include "bench/suites.h"
#include "processing/geometry/ray_caster.h"
#include "processing/radiosity/direct_light.h"
#include "processing/radiosity/hierarchy.h"
#include "processing/radiosity/radiosity_solver.h"
#include "processing/radiosity/reference_scale.h"
#include "processing/radiosity/reflectance.h"
#include "processing/radiosity/scene.h"

namespace relume::bench {
namespace {

namespace rs = radiosity;

struct RandomRoom {
  rs::Mesh mesh;
  std::vector<int> chart_materials;  // the reference patches' materials (chart variant)
  std::vector<Eigen::Vector3d> lamps;
  rs::Rgb lamp_intensity;
  Eigen::Vector3d camera;
  std::string description;
};

rs::Rgb RandomAlbedo(SceneRandom& random) {
  const double grey = random.Uniform(0.1, 0.9);
  rs::Rgb a;
  for (int c = 0; c < 3; ++c) a[c] = std::min(0.92, grey * random.Uniform(0.8, 1.2));
  return a;
}

// The chart variant's reference: six grey patches (2 rows of 3) on one of the two walls the
// camera faces (it stands in the corner at the far_x / far_y sides), at a random place.
void AddChart(const Eigen::Vector3d& size, bool far_x, bool far_y, SceneRandom& random, RandomRoom* room) {
  static constexpr double kNeutral[6] = {0.90, 0.59, 0.36, 0.19, 0.09, 0.03};  // ColorChecker's last row (linear)
  constexpr double kPatch = 0.15, kGap = 0.03, kOff = 0.005;
  const bool on_x_wall = random.Chance(0.5);  // the wall of constant x opposite the camera, else of constant y
  const double length = on_x_wall ? size.y() : size.x();
  const double along = random.Uniform(0.6, length - 0.6 - 3 * kPatch);
  const double height = random.Uniform(0.9, std::min(1.7, size.z() - 0.5));
  // The opposite wall and its inward normal: the wall at 0 faces +, the wall at the far side faces -.
  const bool far_wall = on_x_wall ? !far_x : !far_y;
  const double inward = far_wall ? -1.0 : 1.0;
  const double plane = (far_wall ? (on_x_wall ? size.x() : size.y()) : 0.0) + inward * kOff;
  const Eigen::Vector3d normal = on_x_wall ? Eigen::Vector3d(inward, 0, 0) : Eigen::Vector3d(0, inward, 0);
  auto point = [&](double u, double z) {
    return on_x_wall ? Eigen::Vector3d(plane, u, z) : Eigen::Vector3d(u, plane, z);
  };
  for (int i = 0; i < 6; ++i) {
    const int row = i / 3, col = i % 3;
    const double u0 = along + col * (kPatch + kGap), z0 = height - row * (kPatch + kGap);
    const Eigen::Vector3d a = point(u0, z0), c = point(u0 + kPatch, z0 + kPatch);
    Eigen::Vector3d b = point(u0 + kPatch, z0), d = point(u0, z0 + kPatch);
    if ((b - a).cross(c - a).dot(normal) < 0.0) std::swap(b, d);
    const int material =
        room->mesh.AddMaterial({"chart " + std::to_string(i + 1), rs::Rgb::Constant(kNeutral[i]), rs::Rgb::Zero()});
    room->mesh.AddQuad(a, b, c, d, material);
    room->chart_materials.push_back(material);
  }
}

RandomRoom DrawRoom(std::uint64_t seed, bool chart = false) {
  SceneRandom random(seed);
  RandomRoom room;
  rs::Mesh& m = room.mesh;
  const Eigen::Vector3d size(random.Uniform(3.0, 6.0), random.Uniform(2.5, 5.0), random.Uniform(2.4, 3.2));
  const int floor = m.AddMaterial({"floor", RandomAlbedo(random), rs::Rgb::Zero()});
  const int ceiling = m.AddMaterial({"ceiling", RandomAlbedo(random), rs::Rgb::Zero()});
  const int walls = m.AddMaterial({"walls", RandomAlbedo(random), rs::Rgb::Zero()});
  m.AddRoom({0, 0, 0}, size, floor, ceiling, walls);
  const int boxes = random.Int(1, 3);
  for (int i = 0; i < boxes; ++i) {
    const double w = random.Uniform(0.4, 1.6), d = random.Uniform(0.4, 1.2), h = random.Uniform(0.3, 1.8);
    const double x = random.Uniform(0.1, size.x() - w - 0.1), y = random.Uniform(0.1, size.y() - d - 0.1);
    const int material = m.AddMaterial({"box " + std::to_string(i + 1), RandomAlbedo(random), rs::Rgb::Zero()});
    m.AddBox({x, y, 0.0}, {x + w, y + d, h}, material, /*skip_bottom=*/true);
  }
  const bool desk = random.Chance(0.5);
  if (desk) {
    const double w = random.Uniform(0.8, 1.6), d = random.Uniform(0.5, 0.9), h = random.Uniform(0.65, 0.8);
    const double x = random.Uniform(0.1, size.x() - w - 0.1), y = random.Uniform(0.1, size.y() - d - 0.1);
    const int material = m.AddMaterial({"desk", RandomAlbedo(random), rs::Rgb::Zero()});
    m.AddBox({x, y, h}, {x + w, y + d, h + 0.04}, material);
    for (const auto& [lx, ly] : {std::pair{x, y}, {x + w - 0.04, y}, {x, y + d - 0.04}, {x + w - 0.04, y + d - 0.04}}) {
      m.AddBox({lx, ly, 0.0}, {lx + 0.04, ly + 0.04, h}, material, /*skip_bottom=*/true);
    }
  }
  const int photos = random.Int(2, 5);
  for (int i = 0; i < photos; ++i) {
    room.lamps.push_back({random.Uniform(0.5, size.x() - 0.5), random.Uniform(0.5, size.y() - 0.5),
                          random.Uniform(1.2, size.z() - 0.3)});
  }
  const double level = random.Uniform(5.0, 20.0);
  room.lamp_intensity = level * rs::Rgb(random.Uniform(0.9, 1.1), random.Uniform(0.85, 1.0), random.Uniform(0.7, 0.95));
  const int corner = random.Int(0, 3);
  room.camera = {corner & 1 ? size.x() - 0.2 : 0.2, corner & 2 ? size.y() - 0.2 : 0.2, size.z() - 0.3};
  if (chart) AddChart(size, (corner & 1) != 0, (corner & 2) != 0, random, &room);
  std::ostringstream s;
  s.precision(2);
  s << std::fixed << size.x() << " x " << size.y() << " x " << size.z() << " m room, " << boxes << " box(es)"
    << (desk ? " and a desk" : "") << ", " << photos << " photograph(s)";
  room.description = s.str();
  return room;
}

// One photograph: the patches' radiance (NaN where the camera does not see the centroid),
// with the rendered solution's indirect irradiance (the floor's input) and direct irradiance.
struct Photograph {
  rs::RadianceObservation observation;
  std::vector<rs::Rgb> direct, true_indirect;
};

std::vector<Photograph> Render(const RandomRoom& room, const rs::PatchHierarchy& hierarchy, const RayCaster& caster,
                               bool quick, SceneRandom& noise) {
  rs::RadiosityOptions strict;
  strict.bf_epsilon = quick ? 1e-3 : 2e-4;
  strict.rays_per_form_factor = quick ? 8 : 16;
  strict.residual_tolerance = 1e-6;
  strict.max_iterations = 2000;
  strict.refinement_passes = 3;
  rs::RadiositySolver solver(hierarchy, caster, strict);
  const int n = hierarchy.LeafCount();
  const std::vector<rs::Rgb> albedo = hierarchy.LeafAlbedo();
  std::vector<bool> seen(n, false);
  for (int p = 0; p < n; ++p) {
    const rs::Node& node = hierarchy.leaf(p);
    seen[p] = node.normal.dot(room.camera - node.centroid) > 0.0 &&
              !caster.SegmentOccluded(node.centroid, node.normal, room.camera, Eigen::Vector3d::Zero());
  }
  std::vector<Photograph> out;
  for (const Eigen::Vector3d& lamp : room.lamps) {
    Photograph photo;
    rs::RadianceObservation& obs = photo.observation;
    obs.lighting.point_lights.push_back({lamp, room.lamp_intensity});
    obs.camera_position_m = room.camera;
    // The method computes its own direct light with its default options; the floor uses the
    // same (rs::ReflectanceOptions{}.direct), so that only the indirect light differs.
    photo.direct = rs::ComputeDirectLight(hierarchy, caster, obs.lighting, rs::ReflectanceOptions{}.direct).irradiance;
    const rs::DirectLight render_direct = rs::ComputeDirectLight(hierarchy, caster, obs.lighting, {16, 64});
    rs::RadiositySolution solution;
    solver.Solve(albedo, render_direct.irradiance, hierarchy.LeafEmission(), &solution);
    obs.radiance.assign(n, rs::Rgb::Constant(std::numeric_limits<double>::quiet_NaN()));
    photo.true_indirect.assign(n, rs::Rgb::Zero());
    for (int p = 0; p < n; ++p) {
      // B = rho (E_direct + E_indirect) for a non-emitting patch.
      for (int c = 0; c < 3; ++c) {
        photo.true_indirect[p][c] = solution.radiosity[p][c] / albedo[p][c] - render_direct.irradiance[p][c];
      }
      if (!seen[p]) continue;
      rs::Rgb l = solution.radiosity[p] / std::numbers::pi;
      for (int c = 0; c < 3; ++c) l[c] = std::max(0.0, l[c] * (1.0 + 0.01 * noise.Gaussian()));
      obs.radiance[p] = l;
    }
    out.push_back(std::move(photo));
  }
  return out;
}

// The floor's albedo per patch: the method's own weights, the true indirect light.
std::vector<rs::Rgb> FloorAlbedo(const std::vector<Photograph>& photos, const rs::ReflectanceResult& method, int n) {
  std::vector<rs::Rgb> albedo(n, rs::Rgb::Constant(std::numeric_limits<double>::quiet_NaN()));
  for (int p = 0; p < n; ++p) {
    rs::Rgb sum = rs::Rgb::Zero();
    double weight = 0.0;
    for (std::size_t s = 0; s < photos.size(); ++s) {
      const double w = method.image_weight[s][p];
      const rs::Rgb& l = photos[s].observation.radiance[p];
      if (!(w > 0.0) || !l.allFinite()) continue;
      const rs::Rgb e = photos[s].direct[p] + photos[s].true_indirect[p];
      if (!(e.minCoeff() > 0.0)) continue;
      sum += w * (std::numbers::pi * l).cwiseQuotient(e);
      weight += w;
    }
    if (weight > 0.0) albedo[p] = (sum / weight).cwiseMax(0.0).cwiseMin(1.0);
  }
  return albedo;
}

// Per material: |mean over patches where `use` - truth|, the mean over channels; NaN when no
// patch of the material is used.
std::vector<double> ErrorOfTheMean(const rs::PatchHierarchy& hierarchy, const std::vector<rs::Rgb>& albedo,
                                   const std::vector<bool>& use) {
  const auto& materials = hierarchy.mesh().materials;
  std::vector<rs::Rgb> sum(materials.size(), rs::Rgb::Zero());
  std::vector<int> count(materials.size(), 0);
  for (int p = 0; p < hierarchy.LeafCount(); ++p) {
    if (!use[p] || !albedo[p].allFinite()) continue;
    sum[hierarchy.leaf(p).material] += albedo[p];
    ++count[hierarchy.leaf(p).material];
  }
  std::vector<double> error(materials.size(), std::numeric_limits<double>::quiet_NaN());
  for (std::size_t m = 0; m < materials.size(); ++m) {
    if (count[m] > 0) error[m] = (sum[m] / count[m] - materials[m].albedo).cwiseAbs().mean();
  }
  return error;
}

// A drawn room with its patches, ray caster and photographs (the suites' common setup).
struct RenderedRoom {
  RandomRoom room;
  std::unique_ptr<rs::PatchHierarchy> hierarchy;
  std::unique_ptr<RayCaster> caster;
  std::vector<Photograph> photos;
};

RenderedRoom DrawAndRender(std::uint64_t seed, bool quick, bool chart) {
  RenderedRoom r;
  r.room = DrawRoom(seed, chart);
  rs::HierarchyOptions hierarchy_options;
  hierarchy_options.max_patch_edge_m = quick ? 0.8 : 0.35;
  r.hierarchy = std::make_unique<rs::PatchHierarchy>(r.room.mesh, hierarchy_options);
  r.caster = std::make_unique<RayCaster>(r.room.mesh.geometry);
  SceneRandom noise(seed ^ 0x6e6f697365ULL);
  r.photos = Render(r.room, *r.hierarchy, *r.caster, quick, noise);
  return r;
}

// One suite row: material `m`'s errors of the mean, described by its room and true albedo.
SceneResult MaterialRow(std::uint64_t seed, const RandomRoom& room, const rs::Material& material, double method,
                        double floor, double seconds, std::string notes) {
  SceneResult r;
  r.seed = seed;
  r.method = method;
  r.floor = floor;
  r.seconds = seconds;
  std::ostringstream d;
  d.precision(2);
  d << std::fixed << room.description << "; material " << material.name << " (albedo " << material.albedo.x() << " "
    << material.albedo.y() << " " << material.albedo.z() << ")";
  r.description = d.str();
  r.notes = std::move(notes);
  return r;
}

void RunRoom(std::uint64_t seed, bool quick, std::vector<SceneResult>* out) {
  const RenderedRoom rendered = DrawAndRender(seed, quick, /*chart=*/false);
  const RandomRoom& room = rendered.room;
  const rs::PatchHierarchy& hierarchy = *rendered.hierarchy;
  const RayCaster& caster = *rendered.caster;
  const std::vector<Photograph>& photos = rendered.photos;
  std::vector<rs::RadianceObservation> observations;
  for (const Photograph& p : photos) observations.push_back(p.observation);

  const auto start = std::chrono::steady_clock::now();
  const rs::ReflectanceResult method = rs::EstimateReflectance(hierarchy, caster, observations, {});
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const int n = hierarchy.LeafCount();
  const std::vector<rs::Rgb> floor = FloorAlbedo(photos, method, n);
  std::vector<bool> floor_use(n);
  for (int p = 0; p < n; ++p) floor_use[p] = method.estimated[p] && floor[p].allFinite();
  const std::vector<double> method_error = ErrorOfTheMean(hierarchy, method.albedo, method.estimated);
  const std::vector<double> floor_error = ErrorOfTheMean(hierarchy, floor, floor_use);

  const auto& materials = hierarchy.mesh().materials;
  for (std::size_t m = 0; m < materials.size(); ++m) {
    if (std::isnan(method_error[m]) && std::isnan(floor_error[m])) continue;  // no photograph saw it
    std::ostringstream notes;
    notes << method.iterations << " radiosity iteration(s), " << (method.converged ? "converged" : "NOT converged")
          << ", " << n << " patches, indirect share " << method.indirect.indirect_share;
    out->push_back(MaterialRow(seed, room, materials[m], method_error[m], floor_error[m], seconds, notes.str()));
  }
}

// The chart variant: relative photographs, the scale from the chart, the albedo at that scale.
void RunChartRoom(std::uint64_t seed, bool quick, std::vector<SceneResult>* out) {
  const RenderedRoom rendered = DrawAndRender(seed, quick, /*chart=*/true);
  const RandomRoom& room = rendered.room;
  const rs::PatchHierarchy& hierarchy = *rendered.hierarchy;
  const RayCaster& caster = *rendered.caster;
  const std::vector<Photograph>& photos = rendered.photos;
  SceneRandom units(seed ^ 0x756e697473ULL);
  const double k_true = std::exp(units.Uniform(std::log(0.05), std::log(20.0)));
  std::vector<rs::RadianceObservation> relative;
  for (std::size_t s = 0; s < photos.size(); ++s) {
    relative.push_back(photos[s].observation);
    const double factor = (s == 0 ? 1.0 : units.Uniform(0.5, 2.0)) / k_true;
    for (rs::Rgb& v : relative.back().radiance) v *= factor;
  }
  std::vector<rs::ReferencePatch> references;
  for (int p = 0; p < hierarchy.LeafCount(); ++p) {
    const rs::Node& node = hierarchy.leaf(p);
    const bool chart = std::find(room.chart_materials.begin(), room.chart_materials.end(), node.material) !=
                       room.chart_materials.end();
    if (!chart || !relative[0].radiance[p].allFinite()) continue;
    references.push_back(
        {p, room.mesh.materials[node.material].albedo, relative[0].radiance[p], {node.centroid.cast<float>()}});
  }
  rs::ReflectanceOptions options;
  options.fit_image_scales = true;
  const auto scaled = [&](double k) {
    std::vector<rs::RadianceObservation> o = relative;
    for (rs::RadianceObservation& obs : o) {
      for (rs::Rgb& v : obs.radiance) v *= k;
    }
    return o;
  };
  const auto start = std::chrono::steady_clock::now();
  std::string failure;
  rs::ReferenceScaleResult scale;
  rs::ReflectanceResult method;
  try {
    scale = rs::EstimateReferenceScale(hierarchy, caster, relative, references, options, {});
    method = rs::EstimateReflectance(hierarchy, caster, scaled(scale.scale), options);
  } catch (const std::exception& e) {
    failure = e.what();
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const rs::ReflectanceResult floor = rs::EstimateReflectance(hierarchy, caster, scaled(k_true), options);
  const std::vector<double> floor_error = ErrorOfTheMean(hierarchy, floor.albedo, floor.estimated);
  const std::vector<double> method_error =
      failure.empty() ? ErrorOfTheMean(hierarchy, method.albedo, method.estimated)
                      : std::vector<double>(room.mesh.materials.size(), std::numeric_limits<double>::quiet_NaN());
  const auto& materials = hierarchy.mesh().materials;
  for (std::size_t m = 0; m < materials.size(); ++m) {
    if (std::find(room.chart_materials.begin(), room.chart_materials.end(), static_cast<int>(m)) !=
        room.chart_materials.end()) {
      continue;
    }
    if (std::isnan(floor_error[m])) continue;  // no photograph saw it
    std::ostringstream notes;
    if (!failure.empty()) {
      notes << "failed: " << failure;
    } else {
      notes.precision(4);
      notes << "scale from the chart " << scale.scale / k_true - 1.0 << " relative to the truth (direct light alone "
            << scale.direct_only_scale / k_true - 1.0 << "), " << scale.patches << " reference patches, indirect "
            << scale.indirect_share << " of their light, " << scale.solves << " solves";
    }
    out->push_back(MaterialRow(seed, room, materials[m], method_error[m], floor_error[m], seconds, notes.str()));
  }
}

}  // namespace

std::vector<SuiteResult> RunRadiositySuite(const SuiteOptions& options) {
  SuiteResult result;
  result.suite = "radiosity-rooms";
  result.metric = "albedo error of the mean per material";
  result.method = "Loscos reflectance with radiosity indirect light (defaults), 1 % camera noise";
  result.floor = "true indirect light, the method's weights";
  result.goal_median = 0.01;
  result.goal_p90 = 0.02;
  for (int i = 0; i < options.SceneCount(); ++i) RunRoom(options.SeedOf(i), options.quick, &result.scenes);
  return {result};
}

std::vector<SuiteResult> RunRadiosityChartSuite(const SuiteOptions& options) {
  SuiteResult result;
  result.suite = "radiosity-rooms-chart";
  result.metric = "albedo error of the mean per material";
  result.method = "absolute scale from a grey chart (reference_scale.h), then Loscos reflectance; EV-only photographs";
  result.floor = "the same reflectance estimate at the true scale";
  result.goal_median = 0.01;
  result.goal_p90 = 0.02;
  for (int i = 0; i < options.SceneCount(); ++i) RunChartRoom(options.SeedOf(i), options.quick, &result.scenes);
  return {result};
}

}  // namespace relume::bench
