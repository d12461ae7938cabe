#include "core/mesh.h"

#include <Eigen/Geometry>
#include <cmath>

namespace relume {

bool TriangleMesh::IsValid(std::string* why) const {
  auto fail = [why](const std::string& reason) {
    if (why) *why = reason;
    return false;
  };
  for (const Eigen::Vector3f& p : positions) {
    if (!p.allFinite()) return fail("a vertex position is not finite");
  }
  const int n = static_cast<int>(positions.size());
  for (const Eigen::Vector3i& t : triangles) {
    if (t.minCoeff() < 0 || t.maxCoeff() >= n) return fail("a triangle refers to a vertex that does not exist");
  }
  if (!normals.empty() && normals.size() != positions.size()) return fail("normals must be per vertex");
  if (!albedo.empty() && albedo.size() != positions.size()) return fail("albedo must be per vertex");
  if (!part.empty() && part.size() != positions.size()) return fail("parts must be per vertex");
  if (!material.empty() && material.size() != triangles.size()) return fail("material ids must be per triangle");
  for (const int m : material) {
    if (m < 0) return fail("a triangle's material id is negative");
  }
  return true;
}

void TriangleMesh::ComputeVertexNormals() {
  normals.assign(positions.size(), Eigen::Vector3f::Zero());
  for (const Eigen::Vector3i& t : triangles) {
    const Eigen::Vector3f area_normal =
        (positions[static_cast<std::size_t>(t[1])] - positions[static_cast<std::size_t>(t[0])])
            .cross(positions[static_cast<std::size_t>(t[2])] - positions[static_cast<std::size_t>(t[0])]);
    for (int k = 0; k < 3; ++k) normals[static_cast<std::size_t>(t[k])] += area_normal;
  }
  for (Eigen::Vector3f& n : normals) {
    const float length = n.norm();
    n = length > 0.0f ? Eigen::Vector3f(n / length) : Eigen::Vector3f(0.0f, 0.0f, 1.0f);
  }
}

void TriangleMesh::Append(const TriangleMesh& other) {
  const int offset = static_cast<int>(positions.size());
  const bool keep_normals = !normals.empty() || positions.empty();
  const bool keep_albedo = !albedo.empty() || positions.empty();
  const bool keep_part = !part.empty() || positions.empty();
  const bool keep_material = !material.empty() || triangles.empty();
  const std::size_t triangles_before = triangles.size();
  positions.insert(positions.end(), other.positions.begin(), other.positions.end());
  for (const Eigen::Vector3i& t : other.triangles) triangles.push_back(t + Eigen::Vector3i::Constant(offset));
  if (keep_normals && !other.normals.empty()) normals.insert(normals.end(), other.normals.begin(), other.normals.end());
  if (keep_albedo && !other.albedo.empty()) albedo.insert(albedo.end(), other.albedo.begin(), other.albedo.end());
  if (keep_part && !other.part.empty()) part.insert(part.end(), other.part.begin(), other.part.end());
  if (keep_material && !other.material.empty() && material.size() == triangles_before) {
    material.insert(material.end(), other.material.begin(), other.material.end());
  }
  if (normals.size() != positions.size()) normals.clear();
  if (albedo.size() != positions.size()) albedo.clear();
  if (part.size() != positions.size()) part.clear();
  if (material.size() != triangles.size()) material.clear();
}

TriangleMesh MakeQuad(const Eigen::Vector3f& origin, const Eigen::Vector3f& edge_u, const Eigen::Vector3f& edge_v,
                      int subdivisions) {
  const int n = std::max(1, subdivisions);
  TriangleMesh mesh;
  for (int j = 0; j <= n; ++j) {
    for (int i = 0; i <= n; ++i) {
      mesh.positions.push_back(origin + edge_u * (static_cast<float>(i) / n) + edge_v * (static_cast<float>(j) / n));
    }
  }
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const int a = j * (n + 1) + i;
      mesh.triangles.emplace_back(a, a + 1, a + n + 2);
      mesh.triangles.emplace_back(a, a + n + 2, a + n + 1);
    }
  }
  const Eigen::Vector3f normal = edge_u.cross(edge_v).normalized();
  mesh.normals.assign(mesh.positions.size(), normal);
  return mesh;
}

TriangleMesh MakeBox(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, int subdivisions) {
  const Eigen::Vector3f d = hi - lo;
  const Eigen::Vector3f ex(d.x(), 0, 0), ey(0, d.y(), 0), ez(0, 0, d.z());
  TriangleMesh box;
  box.Append(MakeQuad(lo, ey, ex, subdivisions));       // bottom, normal -z
  box.Append(MakeQuad(lo + ez, ex, ey, subdivisions));  // top, +z
  box.Append(MakeQuad(lo, ex, ez, subdivisions));       // south, -y
  box.Append(MakeQuad(lo + ey, ez, ex, subdivisions));  // north, +y
  box.Append(MakeQuad(lo, ez, ey, subdivisions));       // west, -x
  box.Append(MakeQuad(lo + ex, ey, ez, subdivisions));  // east, +x
  return box;
}

}  // namespace relume
