#include "processing/radiosity/radiosity_solver.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "core/error.h"
#include "processing/radiosity/direct_light.h"

namespace relume::radiosity {
namespace {

// Closed cube room [0, s]^3 seen from inside, one material.
Mesh ClosedRoom(double side_m, const Rgb& albedo, const Rgb& emission = Rgb::Zero()) {
  Mesh mesh;
  const int m = mesh.AddMaterial({"all", albedo, emission});
  mesh.AddRoom({0, 0, 0}, {side_m, side_m, side_m}, m, m, m);
  return mesh;
}

HierarchyOptions Edge(double edge_m) {
  HierarchyOptions options;
  options.max_patch_edge_m = edge_m;
  return options;
}

struct Solved {
  RadiositySummary summary;
  RadiositySolution solution;
};

Solved SolveWith(const PatchHierarchy& h, const RayCaster& caster, const Lighting& lighting,
                 const RadiosityOptions& options = {}) {
  const DirectLight direct = ComputeDirectLight(h, caster, lighting, {});
  RadiositySolver solver(h, caster, options);
  Solved out;
  out.summary = solver.Solve(h.LeafAlbedo(), direct.irradiance, h.LeafEmission(), &out.solution);
  return out;
}

bool AllFinite(const std::vector<Rgb>& values) {
  for (const Rgb& v : values) {
    if (!v.allFinite()) return false;
  }
  return true;
}

TEST(SceneTest, TheMeshIsCoreGeometryWithAMaterialIdPerTriangle) {
  Mesh mesh = ClosedRoom(2.0, Rgb::Constant(0.5));
  const int box = mesh.AddMaterial({"box", Rgb::Constant(0.3), Rgb::Zero()});
  mesh.AddBox({0.5, 0.5, 0.0}, {1.0, 1.5, 0.7}, box, /*skip_bottom=*/true);
  std::string why;
  ASSERT_TRUE(mesh.IsValid(&why)) << why;
  ASSERT_EQ(mesh.geometry.material.size(), mesh.geometry.triangle_count());
  EXPECT_EQ(mesh.TriangleCount(), 12 + 10);  // a room of six quads, a box of five
  EXPECT_EQ(mesh.MaterialOf(mesh.TriangleCount() - 1).name, "box");
  // The box's top, as given, at float precision.
  EXPECT_EQ(mesh.Corner(12, 0), Eigen::Vector3f(0.5f, 0.5f, 0.7f).cast<double>());
  // A material id without its material, or missing for a triangle, is named.
  mesh.geometry.material.back() = 7;
  EXPECT_FALSE(mesh.IsValid(&why));
  EXPECT_NE(why.find("material index out of range"), std::string::npos) << why;
  mesh.geometry.material.pop_back();
  EXPECT_FALSE(mesh.IsValid(&why));
  EXPECT_NE(why.find("one material id per triangle"), std::string::npos) << why;
  mesh.geometry.material.push_back(box);
  // A ray cast against it names the radiosity mesh's triangle: down onto the box's top.
  const RayCaster caster(mesh.geometry);
  const RayCaster::Hit hit = caster.Intersect({0.75f, 1.0f, 1.5f}, {0, 0, -1}, 0.0f, INFINITY);
  ASSERT_TRUE(hit.valid);
  EXPECT_EQ(mesh.geometry.material[static_cast<std::size_t>(hit.triangle)], box);
  EXPECT_NEAR(hit.t, 0.8f, 1e-5f);
}

TEST(FormFactorTest, PointToSquareMatchesClosedForm) {
  // Differential area 1 m below the centre of a 2 m square: four corner rectangles of the
  // classic closed form F = (x/sqrt(1+x^2) atan(y/sqrt(1+x^2)) + y/sqrt(1+y^2) atan(x/sqrt(1+y^2))) / 2pi.
  const auto corner = [](double x, double y) {
    return (x / std::sqrt(1 + x * x) * std::atan(y / std::sqrt(1 + x * x)) +
            y / std::sqrt(1 + y * y) * std::atan(x / std::sqrt(1 + y * y))) /
           (2.0 * std::numbers::pi);
  };
  const Eigen::Vector3d v[4] = {{-1, -1, 1}, {-1, 1, 1}, {1, 1, 1}, {1, -1, 1}};
  const double f =
      PointToPolygonFormFactor(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), v, 4, -Eigen::Vector3d::UnitZ());
  EXPECT_NEAR(f, 4 * corner(1, 1), 1e-12);
}

TEST(FormFactorTest, BackFacingAndBehindGiveZeroAndHorizonClips) {
  const Eigen::Vector3d v[4] = {{-1, -1, 1}, {-1, 1, 1}, {1, 1, 1}, {1, -1, 1}};
  // Polygon facing away from the point (its front is +z, the point is below).
  EXPECT_EQ(PointToPolygonFormFactor(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), v, 4, Eigen::Vector3d::UnitZ()),
            0.0);
  // Receiver facing away from the polygon.
  EXPECT_EQ(
      PointToPolygonFormFactor(Eigen::Vector3d::Zero(), -Eigen::Vector3d::UnitZ(), v, 4, -Eigen::Vector3d::UnitZ()),
      0.0);
  // Receiver tilted so the square straddles its horizon: clipped, so between 0 and the full value.
  const double full =
      PointToPolygonFormFactor(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), v, 4, -Eigen::Vector3d::UnitZ());
  const double half =
      PointToPolygonFormFactor(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(), v, 4, -Eigen::Vector3d::UnitZ());
  EXPECT_GT(half, 0.0);
  EXPECT_LT(half, full);
}

TEST(RadiosityTest, ClosedRoomFormFactorsSumToOne) {
  const Mesh mesh = ClosedRoom(2.0, Rgb::Constant(0.5), Rgb::Constant(1.0));
  const PatchHierarchy h(mesh, Edge(0.5));
  const RayCaster caster(mesh.geometry);
  const Solved s = SolveWith(h, caster, {});
  double mean = 0.0;
  for (double f : s.solution.form_factor_sum) mean += f;
  mean /= h.LeafCount();
  EXPECT_NEAR(mean, 1.0, 0.02);
}

// Furnace test: a closed room with uniform emission E and albedo rho has B = E / (1 - rho).
TEST(RadiosityTest, FurnaceRoomMatchesAnalyticRadiosity) {
  for (double rho : {0.3, 0.7}) {
    const Mesh mesh = ClosedRoom(2.0, Rgb::Constant(rho), Rgb(1.0, 2.0, 0.5));
    const PatchHierarchy h(mesh, Edge(0.5));
    const RayCaster caster(mesh.geometry);
    RadiosityOptions options;
    options.residual_tolerance = 1e-5;
    const Solved s = SolveWith(h, caster, {}, options);
    ASSERT_TRUE(s.summary.converged) << s.summary.BriefReport();
    double mean_error = 0.0;
    for (const Rgb& b : s.solution.radiosity) {
      mean_error +=
          ((b - Rgb(1.0, 2.0, 0.5) / (1.0 - rho)).cwiseAbs().array() / (Rgb(1.0, 2.0, 0.5) / (1 - rho)).array()).mean();
    }
    EXPECT_LT(mean_error / h.LeafCount(), 0.02) << "albedo " << rho;
    // The imbalance is the form-factor deficit at corners (sum_j F_ij < 1 there).
    EXPECT_LT(std::abs(s.summary.balance_error), 0.04) << s.summary.BriefReport();
  }
}

TEST(RadiosityTest, AlbedoNearOneStopsAndSaysWhy) {
  const Mesh mesh = ClosedRoom(2.0, Rgb::Constant(0.99), Rgb::Constant(1.0));
  const PatchHierarchy h(mesh, Edge(1.0));
  const RayCaster caster(mesh.geometry);
  RadiosityOptions options;
  options.residual_tolerance = 1e-4;
  options.max_iterations = 30;
  const Solved s = SolveWith(h, caster, {}, options);
  EXPECT_EQ(s.summary.termination, RadiosityTermination::kMaxIterations) << s.summary.BriefReport();
  EXPECT_FALSE(s.summary.converged);
  EXPECT_NE(s.summary.reason.find("max_iterations"), std::string::npos);
  EXPECT_GT(s.summary.contraction, 0.9);
  EXPECT_TRUE(AllFinite(s.solution.radiosity));
  // Given enough sweeps it converges towards E / (1 - rho) = 100. Near albedo 1 the answer
  // amplifies form-factor errors by 1 / (1 - rho): a 0.1% deficit in sum_j F_ij moves B by
  // about 10%, so the check is the energy balance plus a loose bound on the mean.
  options.max_iterations = 5000;
  options.residual_tolerance = 1e-5;
  const Solved t = SolveWith(h, caster, {}, options);
  EXPECT_TRUE(t.summary.converged) << t.summary.BriefReport();
  double mean = 0.0, area = 0.0;
  for (int p = 0; p < h.LeafCount(); ++p) {
    mean += h.leaf(p).area_m2 * t.solution.radiosity[p].mean();
    area += h.leaf(p).area_m2;
  }
  EXPECT_NEAR(mean / area, 100.0, 10.0);
  EXPECT_LT(std::abs(t.summary.balance_error), 0.01) << t.summary.BriefReport();
}

TEST(RadiosityTest, AlbedoExactlyOneInClosedRoomIsNotContracting) {
  const Mesh mesh = ClosedRoom(2.0, Rgb::Constant(1.0), Rgb::Constant(1.0));
  const PatchHierarchy h(mesh, Edge(2.0));
  const RayCaster caster(mesh.geometry);
  RadiosityOptions options;
  options.max_iterations = 400;
  const Solved s = SolveWith(h, caster, {}, options);
  EXPECT_FALSE(s.summary.converged);
  EXPECT_TRUE(s.summary.termination == RadiosityTermination::kNotContracting ||
              s.summary.termination == RadiosityTermination::kMaxIterations)
      << s.summary.BriefReport();
  EXPECT_TRUE(AllFinite(s.solution.radiosity));
}

TEST(RadiosityTest, NoLightGivesZeroRadiosity) {
  const Mesh mesh = ClosedRoom(2.0, Rgb::Constant(0.5));
  const PatchHierarchy h(mesh, Edge(1.0));
  const RayCaster caster(mesh.geometry);
  const Solved s = SolveWith(h, caster, {});
  EXPECT_EQ(s.summary.termination, RadiosityTermination::kNoLight);
  for (const Rgb& b : s.solution.radiosity) EXPECT_EQ(b.norm(), 0.0);
}

TEST(RadiosityTest, HierarchicalAgreesWithFullMatrixWithFewerFormFactors) {
  Mesh mesh = ClosedRoom(3.0, Rgb::Constant(0.6));
  const int box = mesh.AddMaterial({"box", Rgb::Constant(0.3), Rgb::Zero()});
  mesh.AddBox({1.0, 1.0, 0.0}, {2.0, 1.8, 0.8}, box, true);
  const PatchHierarchy h(mesh, Edge(0.8));
  const RayCaster caster(mesh.geometry);
  Lighting lighting;
  lighting.point_lights.push_back({Eigen::Vector3d(0.7, 0.6, 2.2), Rgb::Constant(10.0)});
  RadiosityOptions full_options;
  full_options.hierarchical = false;
  full_options.residual_tolerance = 1e-4;
  RadiosityOptions hier_options;
  hier_options.residual_tolerance = 1e-4;
  const Solved full = SolveWith(h, caster, lighting, full_options);
  hier_options.bf_epsilon = 0.005;
  const Solved hier = SolveWith(h, caster, lighting, hier_options);
  double diff = 0.0, total = 0.0;
  for (int p = 0; p < h.LeafCount(); ++p) {
    diff += h.leaf(p).area_m2 * (hier.solution.radiosity[p] - full.solution.radiosity[p]).cwiseAbs().mean();
    total += h.leaf(p).area_m2 * full.solution.radiosity[p].mean();
  }
  EXPECT_LT(diff / total, 0.035) << hier.summary.BriefReport() << "\n" << full.summary.BriefReport();
  EXPECT_LT(hier.summary.form_factors, full.summary.form_factors / 2);
}

TEST(DirectLightTest, PointLightIrradianceAndShadow) {
  Mesh mesh;
  const int m = mesh.AddMaterial({"ground", Rgb::Constant(0.5), Rgb::Zero()});
  mesh.AddQuad({-5, -5, 0}, {5, -5, 0}, {5, 5, 0}, {-5, 5, 0}, m);
  mesh.AddBox({-0.2, 2.8, 0.9}, {0.2, 3.2, 1.0}, m);  // floating occluder above (0, 3)
  const PatchHierarchy h(mesh, Edge(0.2));
  const RayCaster caster(mesh.geometry);
  Lighting lighting;
  lighting.point_lights.push_back({Eigen::Vector3d(0, 0, 2), Rgb::Constant(8.0)});
  DirectLightOptions options;
  options.samples_per_patch = 1;  // centroid: exact comparison
  const DirectLight d = ComputeDirectLight(h, caster, lighting, options);
  int checked = 0;
  for (int p = 0; p < h.LeafCount(); ++p) {
    const Node& n = h.leaf(p);
    if (n.normal.z() < 0.99 || n.centroid.z() != 0.0) continue;
    const Eigen::Vector3d to_light = Eigen::Vector3d(0, 0, 2) - n.centroid;
    const double expected = 8.0 * to_light.z() / std::pow(to_light.norm(), 3);
    const Eigen::Vector3d shadow_center(0, 6, 0);  // light (0,0,2) through occluder (0,3,1)
    if ((n.centroid - shadow_center).norm() < 0.4) {
      EXPECT_EQ(d.irradiance[p].mean(), 0.0);
    } else if ((n.centroid - shadow_center).norm() > 1.5) {
      EXPECT_NEAR(d.irradiance[p].x(), expected, 1e-9 * expected);
      ++checked;
    }
  }
  EXPECT_GT(checked, 100);
}

TEST(DirectLightTest, AtPointsAveragesExactlyThosePointsWithTheirShadows) {
  Mesh mesh;
  const int m = mesh.AddMaterial({"ground", Rgb::Constant(0.5), Rgb::Zero()});
  // The ground is one triangle (one patch: the edge limit is larger than it).
  mesh.AddTriangle({-10, -10, 0}, {10, -10, 0}, {0, 10, 0}, m);
  mesh.AddBox({-0.2, 2.8, 0.9}, {0.2, 3.2, 1.0}, m);  // its shadow is centred on (0, 6, 0)
  const PatchHierarchy h(mesh, Edge(100.0));
  const RayCaster caster(mesh.geometry);
  int ground = -1;
  for (int p = 0; p < h.LeafCount(); ++p) {
    if (h.leaf(p).root == 0) ground = p;
  }
  ASSERT_GE(ground, 0);
  Lighting lighting;
  const Eigen::Vector3d lamp(0, 0, 2);
  lighting.point_lights.push_back({lamp, Rgb::Constant(8.0)});
  // Three points lit, at different distances from the lamp, and one in the occluder's shadow.
  const std::vector<Eigen::Vector3d> xs = {{0.1, 0.3, 0}, {0.1, 1.5, 0}, {0.1, 4.0, 0}, {0.0, 6.0, 0}};
  std::vector<double> e;
  for (const Eigen::Vector3d& x : xs) e.push_back(8.0 * (lamp - x).z() / std::pow((lamp - x).norm(), 3));
  std::vector<std::vector<Eigen::Vector3f>> points(h.LeafCount());
  for (const Eigen::Vector3d& x : xs) points[ground].push_back(x.cast<float>());
  const DirectLightAtPoints d = ComputeDirectLightAtPoints(h, caster, lighting, points, {});
  EXPECT_TRUE(d.has_points[ground]);
  const double lit = e[0] + e[1] + e[2];
  EXPECT_NEAR(d.irradiance[ground].x(), lit / 4.0, 1e-9 * lit);
  EXPECT_NEAR(d.visible_fraction[ground], lit / (lit + e[3]), 1e-9);
  // The spread-sample estimate of the same patch is something else entirely (a 20 m triangle).
  const DirectLight spread = ComputeDirectLight(h, caster, lighting, {});
  EXPECT_GT(std::abs(spread.irradiance[ground].x() - lit / 4.0), 0.5 * lit / 4.0);
  for (int p = 0; p < h.LeafCount(); ++p) {
    if (p == ground) continue;
    EXPECT_FALSE(d.has_points[p]);
    EXPECT_EQ(d.irradiance[p], Rgb::Zero());
  }
  // A wrong list count and a non-finite point are errors, not NaN.
  EXPECT_THROW(ComputeDirectLightAtPoints(h, caster, lighting, {}, {}), InvalidArgumentError);
  points[ground].push_back(Eigen::Vector3f(NAN, 0, 0));
  EXPECT_THROW(ComputeDirectLightAtPoints(h, caster, lighting, points, {}), InvalidArgumentError);
}

TEST(DirectLightTest, SpotLightFollowsItsConeAndSmoothstepEdge) {
  Mesh mesh;
  const int m = mesh.AddMaterial({"ground", Rgb::Constant(0.5), Rgb::Zero()});
  mesh.AddQuad({-5, -5, 0}, {5, -5, 0}, {5, 5, 0}, {-5, 5, 0}, m);
  const PatchHierarchy h(mesh, Edge(0.2));
  const RayCaster caster(mesh.geometry);
  PointLight spot{Eigen::Vector3d(0, 0, 2), Rgb::Constant(8.0)};
  spot.spot_direction = Eigen::Vector3d(0, 0, -1);
  spot.cone_half_angle_rad = 30.0 * std::numbers::pi / 180.0;
  spot.falloff_rad = 10.0 * std::numbers::pi / 180.0;
  Lighting lighting;
  lighting.point_lights.push_back(spot);
  DirectLightOptions options;
  options.samples_per_patch = 1;
  const DirectLight d = ComputeDirectLight(h, caster, lighting, options);
  int inside = 0, edge = 0, outside = 0;
  for (int p = 0; p < h.LeafCount(); ++p) {
    const Eigen::Vector3d to_light = Eigen::Vector3d(0, 0, 2) - h.leaf(p).centroid;
    const double angle_deg = std::acos(to_light.z() / to_light.norm()) * 180.0 / std::numbers::pi;
    const double point = 8.0 * to_light.z() / std::pow(to_light.norm(), 3);
    if (angle_deg < 19.9) {
      EXPECT_NEAR(d.irradiance[p].x(), point, 1e-9 * point);
      ++inside;
    } else if (angle_deg > 30.1) {
      EXPECT_EQ(d.irradiance[p].x(), 0.0);
      ++outside;
    } else if (angle_deg > 20.1 && angle_deg < 29.9) {
      const double x = (30.0 - angle_deg) / 10.0;
      EXPECT_NEAR(d.irradiance[p].x(), point * x * x * (3.0 - 2.0 * x), 1e-6 * point);
      ++edge;
    }
  }
  EXPECT_GT(inside, 20);
  EXPECT_GT(edge, 20);
  EXPECT_GT(outside, 100);
  lighting.point_lights[0].falloff_rad = 1.0;  // wider than the cone
  std::string why;
  EXPECT_FALSE(lighting.IsValid(&why));
  EXPECT_NE(why.find("falloff_rad"), std::string::npos) << why;
}

TEST(DirectLightTest, PatchFacingAwayGetsNothing) {
  Mesh mesh;
  const int m = mesh.AddMaterial({"card", Rgb::Constant(0.5), Rgb::Zero()});
  mesh.AddQuad({0, 0, 0}, {0, 1, 0}, {1, 1, 0}, {1, 0, 0}, m);  // normal -z
  const PatchHierarchy h(mesh, Edge(1.0));
  const RayCaster caster(mesh.geometry);
  Lighting lighting;
  lighting.point_lights.push_back({Eigen::Vector3d(0.5, 0.5, 1.0), Rgb::Constant(1.0)});
  const DirectLight d = ComputeDirectLight(h, caster, lighting, {});
  for (const Rgb& e : d.irradiance) EXPECT_EQ(e.norm(), 0.0);
}

TEST(DirectLightTest, SunAndSkyOnOpenGroundAreExact) {
  Mesh mesh;
  const int m = mesh.AddMaterial({"ground", Rgb::Constant(0.2), Rgb::Zero()});
  mesh.AddQuad({-5, -5, 0}, {5, -5, 0}, {5, 5, 0}, {-5, 5, 0}, m);
  const PatchHierarchy h(mesh, Edge(3.0));
  const RayCaster caster(mesh.geometry);
  Lighting lighting;
  SunSky sky;
  sky.sun_dir_in_scene = Eigen::Vector3d(0.6, 0.0, 0.8);
  sky.sun_irradiance_normal = Rgb(900, 850, 800);
  sky.sky_radiance = Rgb(20, 30, 45);
  lighting.sun_sky.push_back(sky);
  const DirectLight d = ComputeDirectLight(h, caster, lighting, {});
  const Rgb expected = 0.8 * sky.sun_irradiance_normal + std::numbers::pi * sky.sky_radiance;
  for (const Rgb& e : d.irradiance) EXPECT_LT((e - expected).norm(), 1e-9 * expected.norm());
}

TEST(DirectLightTest, AreaLightMatchesFormFactor) {
  Mesh mesh;
  const int m = mesh.AddMaterial({"floor", Rgb::Constant(0.5), Rgb::Zero()});
  mesh.AddQuad({-0.01, -0.01, 0}, {0.01, -0.01, 0}, {0.01, 0.01, 0}, {-0.01, 0.01, 0}, m);
  const PatchHierarchy h(mesh, Edge(1.0));
  const RayCaster caster(mesh.geometry);
  Lighting lighting;
  // 2 m square panel 1 m up, facing down: E = pi L F with F from the closed form above.
  lighting.area_lights.push_back(
      {Eigen::Vector3d(-1, -1, 1), Eigen::Vector3d(0, 2, 0), Eigen::Vector3d(2, 0, 0), Rgb::Constant(3.0)});
  DirectLightOptions options;
  options.samples_per_patch = 1;
  const DirectLight d = ComputeDirectLight(h, caster, lighting, options);
  const double x = 1.0;
  const double corner = (x / std::sqrt(2.0) * std::atan(x / std::sqrt(2.0))) * 2.0 / (2.0 * std::numbers::pi);
  // The floor patch's centroid is off the axis by < 1 cm: compare loosely.
  EXPECT_NEAR(d.irradiance[0].x(), std::numbers::pi * 3.0 * 4.0 * corner, 1e-3);
}

TEST(RadiosityTest, TinyAndHugePatchesStayFinite) {
  Mesh mesh;
  const int ground = mesh.AddMaterial({"ground", Rgb::Constant(0.3), Rgb::Zero()});
  const int speck = mesh.AddMaterial({"speck", Rgb::Constant(0.95), Rgb::Zero()});
  mesh.AddQuad({-1000, -1000, 0}, {1000, -1000, 0}, {1000, 1000, 0}, {-1000, 1000, 0}, ground);
  mesh.AddBox({0, 0, 0}, {0.001, 0.001, 0.001}, speck, true);
  const PatchHierarchy h(mesh, Edge(1e4));
  const RayCaster caster(mesh.geometry);
  Lighting lighting;
  SunSky sky;
  sky.sun_dir_in_scene = Eigen::Vector3d(0, 0.6, 0.8);
  sky.sun_irradiance_normal = Rgb::Constant(1000);
  sky.sky_radiance = Rgb::Constant(30);
  lighting.sun_sky.push_back(sky);
  const Solved s = SolveWith(h, caster, lighting);
  EXPECT_TRUE(s.summary.converged) << s.summary.BriefReport();
  EXPECT_TRUE(AllFinite(s.solution.radiosity));
  EXPECT_TRUE(std::isfinite(s.summary.balance_error));
}

TEST(IndirectShareTest, OpenGroundSkipsAndRoomDoesNot) {
  Mesh ground;
  const int m = ground.AddMaterial({"ground", Rgb::Constant(0.3), Rgb::Zero()});
  ground.AddQuad({-5, -5, 0}, {5, -5, 0}, {5, 5, 0}, {-5, 5, 0}, m);
  const PatchHierarchy hg(ground, Edge(2.0));
  const RayCaster cg(ground.geometry);
  Lighting sun;
  sun.sun_sky.push_back({Eigen::Vector3d(0, 0, 1), Rgb::Constant(1000), Rgb::Zero()});
  const DirectLight dg = ComputeDirectLight(hg, cg, sun, {});
  const IndirectShareEstimate open = EstimateIndirectShare(hg, cg, hg.LeafAlbedo(), dg.irradiance, 0.01);
  EXPECT_TRUE(open.skip) << open.reason;
  EXPECT_EQ(open.indirect_share, 0.0);

  const Mesh room = ClosedRoom(3.0, Rgb::Constant(0.7));
  const PatchHierarchy hr(room, Edge(1.0));
  const RayCaster cr(room.geometry);
  Lighting lamp;
  lamp.point_lights.push_back({Eigen::Vector3d(1.5, 1.5, 2.5), Rgb::Constant(5.0)});
  const DirectLight dr = ComputeDirectLight(hr, cr, lamp, {});
  const IndirectShareEstimate closed = EstimateIndirectShare(hr, cr, hr.LeafAlbedo(), dr.irradiance, 0.01);
  EXPECT_FALSE(closed.skip) << closed.reason;
  // A closed room of albedo 0.7: indirect ~ 0.7 / (1 - 0.7) of direct, order of magnitude.
  EXPECT_GT(closed.indirect_share, 1.0);
  EXPECT_NEAR(closed.mean_enclosure, 1.0, 0.1);
}

TEST(OptionsTest, InvalidOptionsAndMeshesAreRejected) {
  std::string why;
  RadiosityOptions r;
  r.rays_per_form_factor = 0;
  EXPECT_FALSE(r.IsValid(&why));
  r = {};
  r.residual_tolerance = 0.0;
  EXPECT_FALSE(r.IsValid(&why));
  HierarchyOptions ho;
  ho.max_patch_edge_m = -1.0;
  EXPECT_FALSE(ho.IsValid(&why));
  Mesh mesh;
  const int m = mesh.AddMaterial({"bad", Rgb::Constant(1.2), Rgb::Zero()});
  mesh.AddQuad({0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, m);
  EXPECT_THROW(PatchHierarchy(mesh, HierarchyOptions{}), InvalidArgumentError);
  Mesh degenerate;
  const int d = degenerate.AddMaterial({"ok", Rgb::Constant(0.5), Rgb::Zero()});
  degenerate.AddQuad({0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}, d);
  EXPECT_FALSE(degenerate.IsValid(&why));
  EXPECT_NE(why.find("degenerate"), std::string::npos);
}

}  // namespace
}  // namespace relume::radiosity
