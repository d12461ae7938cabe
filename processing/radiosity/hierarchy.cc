#include "processing/radiosity/hierarchy.h"

#include <cmath>
#include <limits>

#include "core/error.h"

namespace relume::radiosity {

bool HierarchyOptions::IsValid(std::string* why) const {
  if (!(max_patch_edge_m > 0.0) || !std::isfinite(max_patch_edge_m)) {
    if (why) *why = "max_patch_edge_m must be a positive number of metres";
    return false;
  }
  if (max_depth < 0 || max_depth > 20) {
    if (why) *why = "max_depth must be in [0, 20]";
    return false;
  }
  return true;
}

PatchHierarchy::PatchHierarchy(const Mesh& mesh, const HierarchyOptions& options) : mesh_(mesh) {
  ThrowIfInvalid(options, "radiosity hierarchy options");
  ThrowIfInvalid(mesh, "radiosity mesh");
  roots_.reserve(static_cast<std::size_t>(mesh.TriangleCount()));
  for (int t = 0; t < mesh.TriangleCount(); ++t) {
    Node root;
    root.triangle = {mesh.Corner(t, 0), mesh.Corner(t, 1), mesh.Corner(t, 2)};
    root.root = t;
    root.material = mesh.geometry.material[static_cast<std::size_t>(t)];
    roots_.push_back(static_cast<int>(nodes_.size()));
    nodes_.push_back(root);
  }
  for (int t = 0; t < mesh.TriangleCount(); ++t) Build(roots_[t], options);
}

void PatchHierarchy::Build(int id, const HierarchyOptions& options) {
  {
    Node& node = nodes_[id];
    node.normal = node.triangle.Normal();
    node.centroid = node.triangle.Centroid();
    node.area_m2 = node.triangle.Area();
  }
  const Node node = nodes_[id];
  const double wanted = options.max_patch_edge_at ? options.max_patch_edge_at(node.triangle) : options.max_patch_edge_m;
  if (node.level >= options.max_depth || !(node.triangle.LongestEdge() > wanted)) {
    nodes_[id].leaf = static_cast<int>(leaves_.size());
    leaves_.push_back(id);
    return;
  }
  const Triangle& t = node.triangle;
  const Eigen::Vector3d m01 = 0.5 * (t.v0 + t.v1), m12 = 0.5 * (t.v1 + t.v2), m20 = 0.5 * (t.v2 + t.v0);
  const Triangle children[4] = {{t.v0, m01, m20}, {m01, t.v1, m12}, {m20, m12, t.v2}, {m01, m12, m20}};
  const int first = static_cast<int>(nodes_.size());
  nodes_[id].first_child = first;
  for (int c = 0; c < 4; ++c) {
    Node child;
    child.triangle = children[c];
    child.root = node.root;
    child.parent = id;
    child.level = node.level + 1;
    child.path = (node.path << 2u) | static_cast<std::uint64_t>(c);
    child.material = node.material;
    nodes_.push_back(child);
  }
  for (int c = 0; c < 4; ++c) Build(first + c, options);
}

std::vector<Rgb> PatchHierarchy::LeafAlbedo() const {
  std::vector<Rgb> out;
  out.reserve(leaves_.size());
  for (int id : leaves_) out.push_back(mesh_.materials[nodes_[id].material].albedo);
  return out;
}

std::vector<Rgb> PatchHierarchy::LeafEmission() const {
  std::vector<Rgb> out;
  out.reserve(leaves_.size());
  for (int id : leaves_) out.push_back(mesh_.materials[nodes_[id].material].emitted_radiosity);
  return out;
}

int PatchHierarchy::Find(int root, int level, std::uint64_t path) const {
  RELUME_CHECK(root >= 0 && root < static_cast<int>(roots_.size()));
  int id = roots_[root];
  for (int l = 1; l <= level; ++l) {
    if (nodes_[id].IsLeaf()) break;
    const int digit = static_cast<int>((path >> (2u * static_cast<unsigned>(level - l))) & 3u);
    id = nodes_[id].first_child + digit;
  }
  return id;
}

Rgb PatchHierarchy::NodeMean(int id, const std::vector<Rgb>& per_patch) const {
  Rgb sum = Rgb::Zero();
  double area = 0.0;
  std::vector<int> stack = {id};
  while (!stack.empty()) {
    const Node& n = nodes_[stack.back()];
    stack.pop_back();
    if (n.IsLeaf()) {
      const Rgb& v = per_patch[n.leaf];
      if (v.allFinite()) {
        sum += n.area_m2 * v;
        area += n.area_m2;
      }
    } else {
      for (int c = 0; c < 4; ++c) stack.push_back(n.first_child + c);
    }
  }
  if (!(area > 0.0)) return Rgb::Constant(std::numeric_limits<double>::quiet_NaN());
  return sum / area;
}

std::vector<Rgb> ResamplePatches(const PatchHierarchy& from, const std::vector<Rgb>& values, const PatchHierarchy& to) {
  RELUME_CHECK(static_cast<int>(values.size()) == from.LeafCount());
  RELUME_CHECK(from.roots().size() == to.roots().size());
  std::vector<Rgb> out(to.LeafCount());
  for (int p = 0; p < to.LeafCount(); ++p) {
    const Node& target = to.leaf(p);
    out[p] = from.NodeMean(from.Find(target.root, target.level, target.path), values);
  }
  return out;
}

}  // namespace relume::radiosity
