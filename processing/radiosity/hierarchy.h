// Patch hierarchy: every mesh triangle is the root of a quadtree of triangles (midpoint
// subdivision into four similar children), refined until each leaf's longest edge is at most
// the requested size. Leaves are the radiosity patches; interior nodes are where hierarchical
// radiosity links coarse interactions.
//
// Conventions: see scene.h. Node ids are indices into nodes(); leaf ids index leaves() and
// are what per-patch arrays (albedo, radiance, irradiance) are indexed by. A node's `path` is
// its child digits (2 bits per level, root first), so (root, level, path) names the same
// piece of surface in any two hierarchies built from the same mesh.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "processing/radiosity/geometry.h"
#include "processing/radiosity/scene.h"

namespace relume::radiosity {

struct HierarchyOptions {
  double max_patch_edge_m = 0.25;  // leaves are split until their longest edge is at most this
  int max_depth = 12;              // hard limit on quadtree depth (4^12 leaves per triangle)
  // Optional: patch edge wanted for a node, from its triangle (overrides max_patch_edge_m).
  // Used by block processing to give regions different resolutions.
  std::function<double(const Triangle&)> max_patch_edge_at;
  bool IsValid(std::string* why) const;
};

struct Node {
  Triangle triangle;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  double area_m2 = 0.0;
  int root = -1;  // mesh triangle index
  int parent = -1;
  int first_child = -1;  // children are first_child .. first_child + 3; -1 for a leaf
  int level = 0;
  std::uint64_t path = 0;
  int leaf = -1;  // index into leaves() for a leaf, else -1
  int material = 0;
  bool IsLeaf() const { return first_child < 0; }
};

class PatchHierarchy {
 public:
  // Throws InvalidArgumentError when the mesh or options are invalid.
  PatchHierarchy(const Mesh& mesh, const HierarchyOptions& options);

  const Mesh& mesh() const { return mesh_; }
  const std::vector<Node>& nodes() const { return nodes_; }
  const std::vector<int>& roots() const { return roots_; }    // node id per mesh triangle
  const std::vector<int>& leaves() const { return leaves_; }  // node id per patch
  int LeafCount() const { return static_cast<int>(leaves_.size()); }
  const Node& leaf(int patch) const { return nodes_[leaves_[patch]]; }
  // Per-patch material albedo / emission from the mesh.
  std::vector<Rgb> LeafAlbedo() const;
  std::vector<Rgb> LeafEmission() const;
  // The node covering (root, level, path), or the deepest existing ancestor of it.
  int Find(int root, int level, std::uint64_t path) const;
  // Area-weighted mean over a node's leaves of a per-patch quantity.
  Rgb NodeMean(int node, const std::vector<Rgb>& per_patch) const;

 private:
  void Build(int node, const HierarchyOptions& options);
  Mesh mesh_;
  std::vector<Node> nodes_;
  std::vector<int> roots_;
  std::vector<int> leaves_;
};

// Per-patch values of hierarchy `from` carried to the patches of `to` (same mesh): a target
// patch covering several source patches gets their area-weighted mean, one inside a coarser
// source patch gets that patch's value. Non-finite source values are skipped; a target with
// no finite source gets NaN (meaning "not observed", as in radiance inputs).
std::vector<Rgb> ResamplePatches(const PatchHierarchy& from, const std::vector<Rgb>& values, const PatchHierarchy& to);

}  // namespace relume::radiosity
