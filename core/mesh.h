// A triangle mesh in a scene frame (metres; ENU unless a name says otherwise).
//
// Conventions: triangles wind counter-clockwise seen from the side their normal points to;
// per-vertex normals are unit length; albedo (when present) is linear-sRGB Lambertian
// reflectance per vertex.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace relume {

struct TriangleMesh {
  std::vector<Eigen::Vector3f> positions;
  std::vector<Eigen::Vector3i> triangles;
  std::vector<Eigen::Vector3f> normals;  // per vertex; empty until computed
  std::vector<Eigen::Vector3f> albedo;   // per vertex; optional
  // Per vertex, optional: which part of the scene (an object of a scene model, a connected
  // piece of a mesh file) the vertex belongs to, for guesses about surfaces no photograph shows
  // (processing/irm: a hidden face takes its own object's reflectance, not the ground's).
  std::vector<int> part;
  // Per triangle, optional: a material id, the index into a material table the mesh's owner
  // keeps (radiosity::Mesh::materials: albedo and emission; a scene model's materials).
  std::vector<int> material;

  std::size_t vertex_count() const { return positions.size(); }
  std::size_t triangle_count() const { return triangles.size(); }
  // False (with the reason) for out-of-range indices, NaN positions, size mismatches or a
  // negative material id (the table's size is its owner's to check).
  bool IsValid(std::string* why) const;
  // Area-weighted vertex normals from the triangles' winding.
  void ComputeVertexNormals();
  // Appends another mesh (vertex indices shifted, material ids kept: both meshes' ids must refer
  // to one table). An optional attribute stays only when both meshes have it.
  void Append(const TriangleMesh& other);
};

// Building blocks for procedural scenes and tests, with outward normals and `subdivisions`
// splits per edge (so that vertices sample surfaces densely).
TriangleMesh MakeQuad(const Eigen::Vector3f& origin, const Eigen::Vector3f& edge_u, const Eigen::Vector3f& edge_v,
                      int subdivisions);
TriangleMesh MakeBox(const Eigen::Vector3f& min_corner, const Eigen::Vector3f& max_corner, int subdivisions);

}  // namespace relume
