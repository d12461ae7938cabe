#include "pipeline/irm_scene.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "core/error.h"
#include "core/frames.h"
#include "core/mesh_io.h"

namespace relume::pipeline {

bool IrmMeshOptions::IsValid(std::string* why) const {
  if (!(spacing_m >= 0.01 && spacing_m <= 100.0)) {
    if (why) *why = "mesh_spacing_m must be within [0.01, 100] m";
    return false;
  }
  if (sphere_segments < 8 || sphere_segments > 1024) {
    if (why) *why = "sphere segments must be within 8..1024";
    return false;
  }
  return true;
}

namespace {

// A triangle split into n x n smaller ones (barycentric grid), with its own vertices, all in
// `part` (TriangleMesh::part).
void AppendSplitTriangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                         const Eigen::Vector3f& albedo, int part, double spacing_m, TriangleMesh* out) {
  const Eigen::Vector3d cross = (b - a).cross(c - a);
  if (!(cross.norm() > 1e-12)) return;  // degenerate: no area, no normal
  const Eigen::Vector3f normal = cross.normalized().cast<float>();
  const double longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
  const int n = std::max(1, static_cast<int>(std::ceil(longest / spacing_m)));
  const int base = static_cast<int>(out->positions.size());
  auto index = [&](int i, int j) { return base + j * (n + 1) - j * (j - 1) / 2 + i; };  // row j has n + 1 - j vertices
  for (int j = 0; j <= n; ++j) {
    for (int i = 0; i <= n - j; ++i) {
      const double u = static_cast<double>(i) / n, v = static_cast<double>(j) / n;
      out->positions.push_back((a + (b - a) * u + (c - a) * v).cast<float>());
      out->normals.push_back(normal);
      out->albedo.push_back(albedo);
      out->part.push_back(part);
    }
  }
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n - j; ++i) {
      out->triangles.emplace_back(index(i, j), index(i + 1, j), index(i, j + 1));
      if (i + 1 < n - j) out->triangles.emplace_back(index(i + 1, j), index(i + 1, j + 1), index(i, j + 1));
    }
  }
}

Eigen::Vector3f FaceAlbedo(const MeshData& mesh, std::size_t face, const Eigen::Vector3d& fallback) {
  if (face < mesh.face_albedo.size() && mesh.face_albedo[face].allFinite()) return mesh.face_albedo[face].cast<float>();
  return fallback.cast<float>();
}

// The connected pieces of a mesh file (triangles that share a vertex index), numbered from 0
// per triangle: the parts (TriangleMesh::part) of the split mesh.
std::vector<int> ConnectedPieces(const MeshData& mesh) {
  std::vector<int> parent(mesh.vertices.size());
  for (std::size_t i = 0; i < parent.size(); ++i) parent[i] = static_cast<int>(i);
  auto find = [&parent](int v) {
    while (parent[static_cast<std::size_t>(v)] != v) {
      parent[static_cast<std::size_t>(v)] = parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(v)])];
      v = parent[static_cast<std::size_t>(v)];
    }
    return v;
  };
  for (const Eigen::Vector3i& t : mesh.triangles) {
    parent[static_cast<std::size_t>(find(t[1]))] = find(t[0]);
    parent[static_cast<std::size_t>(find(t[2]))] = find(t[0]);
  }
  std::vector<int> number(mesh.vertices.size(), -1), pieces;
  int next = 0;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    int& n = number[static_cast<std::size_t>(find(t[0]))];
    if (n < 0) n = next++;
    pieces.push_back(n);
  }
  return pieces;
}

TriangleMesh SplitMesh(const MeshData& mesh, const Eigen::Vector3d& albedo, double spacing_m) {
  TriangleMesh out;
  const std::vector<int> pieces = ConnectedPieces(mesh);
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const Eigen::Vector3i& t = mesh.triangles[f];
    AppendSplitTriangle(mesh.vertices[static_cast<std::size_t>(t[0])], mesh.vertices[static_cast<std::size_t>(t[1])],
                        mesh.vertices[static_cast<std::size_t>(t[2])], FaceAlbedo(mesh, f, albedo), pieces[f],
                        spacing_m, &out);
  }
  return out;
}

TriangleMesh Sphere(const Eigen::Vector3d& center, double radius, const Eigen::Vector3d& albedo, int segments) {
  TriangleMesh out;
  const int rings = std::max(4, segments / 2);
  for (int j = 0; j <= rings; ++j) {
    const double theta = std::numbers::pi * j / rings;  // from the north pole
    for (int i = 0; i <= segments; ++i) {
      const double phi = 2.0 * std::numbers::pi * i / segments;
      const Eigen::Vector3d n(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
      out.positions.push_back((center + radius * n).cast<float>());
      out.normals.push_back(n.cast<float>());
      out.albedo.push_back(albedo.cast<float>());
    }
  }
  for (int j = 0; j < rings; ++j) {
    for (int i = 0; i < segments; ++i) {
      const int a = j * (segments + 1) + i, b = a + segments + 1;
      // Counter-clockwise seen from outside.
      if (j > 0) out.triangles.emplace_back(a, b, a + 1);
      if (j + 1 < rings) out.triangles.emplace_back(a + 1, b, b + 1);
    }
  }
  return out;
}

}  // namespace

TriangleMesh ProcessingMeshFromData(const MeshData& mesh, const IrmMeshOptions& options) {
  ThrowIfInvalid(options, "IRM mesh options");
  return SplitMesh(mesh, Eigen::Vector3d::Constant(0.5), options.spacing_m);
}

TriangleMesh ProcessingMeshFromModel(const SceneModel& model, const IrmMeshOptions& options) {
  ThrowIfInvalid(options, "IRM mesh options");
  // Known reflectance where the model has it (a chart's patches), else a neutral 0.5: the IRM
  // itself never reads albedo; it is kept for previews.
  const auto albedo_of = [&model](int material) -> Eigen::Vector3d {
    const std::optional<Eigen::Vector3d>& known = model.materials[static_cast<std::size_t>(material)].albedo;
    return known ? *known : Eigen::Vector3d::Constant(0.5);
  };
  TriangleMesh out;
  // Each object is a part (TriangleMesh::part).
  for (std::size_t o = 0; o < model.objects.size(); ++o) {
    const SceneModelObject& object = model.objects[o];
    const int part = static_cast<int>(o);
    if (object.kind == SceneModelObject::Kind::kSphere) {
      TriangleMesh sphere =
          Sphere(object.sphere_center, object.sphere_radius_m, albedo_of(object.material), options.sphere_segments);
      sphere.part.assign(sphere.vertex_count(), part);
      out.Append(sphere);
      continue;
    }
    for (std::size_t f = 0; f < object.triangles.size(); ++f) {
      const Eigen::Vector3i& t = object.triangles[f];
      AppendSplitTriangle(object.vertices[static_cast<std::size_t>(t[0])],
                          object.vertices[static_cast<std::size_t>(t[1])],
                          object.vertices[static_cast<std::size_t>(t[2])],
                          albedo_of(object.face_material[f]).cast<float>(), part, options.spacing_m, &out);
    }
  }
  return out;
}

LoadedSceneMesh LoadSceneMesh(const std::string& path, MeshFrame frame, const Site& site, std::optional<int> utm_zone,
                              const IrmMeshOptions& options) {
  ThrowIfInvalid(options, "IRM mesh options");
  MeshData mesh = LoadMesh(path);
  if (mesh.triangles.empty()) throw InvalidArgumentError("mesh " + path + " has no triangles");
  LoadedSceneMesh loaded;
  if (frame == MeshFrame::kUtm) {
    const UtmGridFrame grid(site, utm_zone);
    const EnuFrame enu(site);
    for (Eigen::Vector3d& v : mesh.vertices) v = enu.EnuFromGeodetic(grid.GeodeticFromGrid(v));
    loaded.convergence_rad = grid.convergence_rad();
    loaded.utm_zone = grid.zone();
  }
  std::string why;
  if (!mesh.IsValid(&why)) throw InvalidArgumentError("mesh " + path + ": " + why);
  loaded.mesh = ProcessingMeshFromData(mesh, options);
  return loaded;
}

}  // namespace relume::pipeline
