#include "processing/radiosity/radiosity_solver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "core/error.h"

namespace relume::radiosity {
namespace {

constexpr double kShiftU = 0.4142, kShiftV = 0.7320;  // source-side sample rotation

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

double Scalar(const Rgb& c) {
  return c.mean();
}

void CheckPerPatch(const std::vector<Rgb>& values, int n, const char* what, bool at_most_one) {
  if (static_cast<int>(values.size()) != n) {
    throw InvalidArgumentError(std::string("radiosity: ") + what + " has " + std::to_string(values.size()) +
                               " entries; the hierarchy has " + std::to_string(n) + " patches");
  }
  for (const Rgb& v : values) {
    if (!v.allFinite() || v.minCoeff() < 0.0 || (at_most_one && v.maxCoeff() > 1.0)) {
      throw InvalidArgumentError(std::string("radiosity: ") + what +
                                 (at_most_one ? " must be finite and in [0, 1]" : " must be finite and >= 0"));
    }
  }
}

// True when some vertex of `a` lies strictly in front of the plane of `b`.
bool AnyInFront(const Node& a, const Node& b) {
  const Eigen::Vector3d& o = b.triangle.v0;
  const double scale = 1e-9 * std::sqrt(b.area_m2 + a.area_m2);
  return (a.triangle.v0 - o).dot(b.normal) > scale || (a.triangle.v1 - o).dot(b.normal) > scale ||
         (a.triangle.v2 - o).dot(b.normal) > scale;
}

}  // namespace

const char* ToString(RadiosityTermination termination) {
  switch (termination) {
    case RadiosityTermination::kConverged: return "converged";
    case RadiosityTermination::kNoLight: return "no light";
    case RadiosityTermination::kMaxIterations: return "max iterations";
    case RadiosityTermination::kNotContracting: return "not contracting";
  }
  return "?";
}

bool RadiosityOptions::IsValid(std::string* why) const {
  const auto fail = [&](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (!(bf_epsilon >= 0.0) || !std::isfinite(bf_epsilon)) return fail("bf_epsilon must be finite and >= 0");
  if (rays_per_form_factor < 1 || rays_per_form_factor > 1024) return fail("rays_per_form_factor must be in [1, 1024]");
  if (refinement_passes < 1 || refinement_passes > 10) return fail("refinement_passes must be in [1, 10]");
  if (!(residual_tolerance > 0.0) || !(residual_tolerance < 1.0)) return fail("residual_tolerance must be in (0, 1)");
  if (max_iterations < 1) return fail("max_iterations must be >= 1");
  if (max_links < 1) return fail("max_links must be >= 1");
  return true;
}

std::string RadiositySummary::BriefReport() const {
  std::ostringstream out;
  out << "radiosity: " << ToString(termination) << " after " << iterations << " iterations, residual " << residual
      << " (contraction " << contraction << ", est. error " << estimated_error << "), " << patches << " patches, "
      << links << " links, " << form_factors << " new form factors, " << rays << " rays, energy in " << power_in
      << " absorbed " << power_absorbed << " escaped " << power_escaped << " (balance error " << balance_error
      << "), refine " << refine_time_s << " s, solve " << solve_time_s << " s";
  if (!reason.empty()) out << "; " << reason;
  return out.str();
}

RadiositySolver::RadiositySolver(const PatchHierarchy& hierarchy, const RayCaster& caster,
                                 const RadiosityOptions& options)
    : h_(hierarchy), caster_(caster), options_(options) {
  ThrowIfInvalid(options, "radiosity options");
  const auto& nodes = h_.nodes();
  node_b_.assign(nodes.size(), Rgb::Zero());
  root_order_.resize(h_.roots().size());
  for (size_t r = 0; r < h_.roots().size(); ++r) {
    std::vector<int>& order = root_order_[r];
    order.push_back(h_.roots()[r]);
    for (size_t i = 0; i < order.size(); ++i) {
      const Node& n = nodes[order[i]];
      if (!n.IsLeaf()) {
        for (int c = 0; c < 4; ++c) order.push_back(n.first_child + c);
      }
    }
  }
}

bool RadiositySolver::Interacts(int p, int q) const {
  const Node& a = h_.nodes()[p];
  const Node& b = h_.nodes()[q];
  if (a.root == b.root) return false;  // a mesh triangle is planar: its parts never see each other
  return AnyInFront(a, b) && AnyInFront(b, a);
}

void RadiositySolver::ComputeLink(int p, int q) {
  const auto& nodes = h_.nodes();
  // Sample the smaller node (points x_k), integrate the larger one analytically from each x_k,
  // and test visibility with one ray from x_k to a sample y_k on the larger one.
  const bool p_small = nodes[p].area_m2 <= nodes[q].area_m2;
  const Node& a = nodes[p_small ? p : q];
  const Node& b = nodes[p_small ? q : p];
  const int n = options_.rays_per_form_factor;
  double sum = 0.0;
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector2d ua = n == 1 ? Eigen::Vector2d(0.5, 0.5) : Hammersley(k, n);
    const Eigen::Vector2d ub = n == 1 ? Eigen::Vector2d(0.5, 0.5) : Hammersley(k, n, kShiftU, kShiftV);
    const Eigen::Vector3d x = n == 1 ? a.centroid : a.triangle.PointAt(ua.x(), ua.y());
    const Eigen::Vector3d y = n == 1 ? b.centroid : b.triangle.PointAt(ub.x(), ub.y());
    const double f = PointToTriangleFormFactor(x, a.normal, b.triangle);
    if (f <= 0.0) continue;
    if (!caster_.SegmentOccluded(x, a.normal, y, b.normal)) sum += f;
  }
  const double f_ab = sum / n;
  const double f_ba = f_ab * a.area_m2 / b.area_m2;
  ++form_factors_;
  if (f_ab <= 0.0) return;  // fully occluded: no link needed
  PairLink link;
  link.p = p;
  link.q = q;
  link.f_pq = static_cast<float>(p_small ? f_ab : f_ba);
  link.f_qp = static_cast<float>(p_small ? f_ba : f_ab);
  link.alive = true;
  pairs_.push_back(link);
  ++alive_links_;
}

void RadiositySolver::Refine(int p, int q, int depth) {
  if (!Interacts(p, q)) return;
  const auto& nodes = h_.nodes();
  const Node& a = nodes[p];
  const Node& b = nodes[q];
  const bool can_p = !a.IsLeaf(), can_q = !b.IsLeaf();
  bool refine = false;
  double est_pq = 0.0, est_qp = 0.0;
  if ((can_p || can_q) && !budget_hit_) {
    if (!options_.hierarchical) {
      refine = true;
    } else {
      est_pq = PointToTriangleFormFactor(a.centroid, a.normal, b.triangle);
      est_qp = PointToTriangleFormFactor(b.centroid, b.normal, a.triangle);
      // A pair whose centroids do not see each other while parts do (straddling planes) has an
      // unreliable estimate: refine it.
      const bool straddling = est_pq <= 0.0 || est_qp <= 0.0;
      const double err = std::max(oracle_albedo_[p] * est_pq * oracle_b_[q], oracle_albedo_[q] * est_qp * oracle_b_[p]);
      refine = straddling || err > oracle_threshold_;
    }
  }
  if (alive_links_ >= options_.max_links) budget_hit_ = true;
  if (!refine || budget_hit_) {
    ComputeLink(p, q);
    return;
  }
  // Split the node that subtends the larger solid angle from the other one (HSA's rule).
  const bool split_q = can_q && (!can_p || est_pq >= est_qp);
  if (!options_.hierarchical && can_p && can_q) {
    const bool split_p_first = a.area_m2 >= b.area_m2;
    const int s = split_p_first ? p : q;
    for (int c = 0; c < 4; ++c) {
      const int child = nodes[s].first_child + c;
      split_p_first ? Refine(child, q, depth + 1) : Refine(p, child, depth + 1);
    }
    return;
  }
  if (split_q) {
    for (int c = 0; c < 4; ++c) Refine(p, b.first_child + c, depth + 1);
  } else {
    for (int c = 0; c < 4; ++c) Refine(a.first_child + c, q, depth + 1);
  }
}

void RadiositySolver::PullOracle(const std::vector<Rgb>& leaf_b, const std::vector<Rgb>& albedo) {
  const auto& nodes = h_.nodes();
  oracle_b_.assign(nodes.size(), 0.0);
  oracle_albedo_.assign(nodes.size(), 0.0);
  double total = 0.0, area = 0.0;
  for (const auto& order : root_order_) {
    for (auto it = order.rbegin(); it != order.rend(); ++it) {
      const Node& n = nodes[*it];
      if (n.IsLeaf()) {
        oracle_b_[*it] = Scalar(leaf_b[n.leaf]);
        oracle_albedo_[*it] = albedo[n.leaf].maxCoeff();
        total += n.area_m2 * oracle_b_[*it];
        area += n.area_m2;
      } else {
        double b = 0.0, rho = 0.0;
        for (int c = 0; c < 4; ++c) {
          const Node& child = nodes[n.first_child + c];
          b += child.area_m2 * oracle_b_[n.first_child + c];
          rho = std::max(rho, oracle_albedo_[n.first_child + c]);
        }
        oracle_b_[*it] = b / n.area_m2;
        oracle_albedo_[*it] = rho;
      }
    }
  }
  oracle_threshold_ = options_.bf_epsilon * (area > 0.0 ? total / area : 0.0);
}

void RadiositySolver::CompileLinks() {
  const size_t n = h_.nodes().size();
  std::vector<int> count(n + 1, 0);
  for (const PairLink& l : pairs_) {
    if (!l.alive) continue;
    ++count[l.p + 1];
    ++count[l.q + 1];
  }
  in_offset_.assign(n + 1, 0);
  for (size_t i = 0; i < n; ++i) in_offset_[i + 1] = in_offset_[i] + count[i + 1];
  in_source_.assign(in_offset_[n], 0);
  in_f_.assign(in_offset_[n], 0.0f);
  std::vector<int> fill(in_offset_.begin(), in_offset_.end() - 1);
  for (const PairLink& l : pairs_) {
    if (!l.alive) continue;
    in_source_[fill[l.p]] = l.q;
    in_f_[fill[l.p]++] = l.f_pq;
    in_source_[fill[l.q]] = l.p;
    in_f_[fill[l.q]++] = l.f_qp;
  }
}

double RadiositySolver::Sweep(const std::vector<Rgb>& albedo, const std::vector<Rgb>& direct,
                              const std::vector<Rgb>& emission, std::vector<Rgb>* gathered_total) {
  const auto& nodes = h_.nodes();
  double change = 0.0;
  std::vector<Rgb> down;  // irradiance pushed down from ancestors, per position in `order`
  for (const auto& order : root_order_) {
    down.assign(order.size(), Rgb::Zero());
    // Gather at every node of this triangle's tree, and push down (parents come first).
    std::vector<Rgb>& pushed = down;
    for (size_t i = 0; i < order.size(); ++i) {
      const int id = order[i];
      Rgb g = Rgb::Zero();
      for (int k = in_offset_[id]; k < in_offset_[id + 1]; ++k)
        g += static_cast<double>(in_f_[k]) * node_b_[in_source_[k]];
      pushed[i] += g;
    }
    // Children of order[i] sit at consecutive positions in `order` (breadth-first fill): the
    // j-th interior node in order has its children at 1 + 4 * j .. 4 + 4 * j.
    int interior = 0;
    for (size_t i = 0; i < order.size(); ++i) {
      const Node& n = nodes[order[i]];
      if (n.IsLeaf()) continue;
      const size_t first = 1 + 4 * static_cast<size_t>(interior++);
      for (int c = 0; c < 4; ++c) pushed[first + c] += pushed[i];
    }
    // Leaves: new radiosity; then pull up (children before parents).
    for (size_t i = order.size(); i-- > 0;) {
      const int id = order[i];
      const Node& n = nodes[id];
      if (n.IsLeaf()) {
        const int p = n.leaf;
        const Rgb b = emission[p] + albedo[p].cwiseProduct(direct[p] + pushed[i]);
        change += n.area_m2 * Scalar((b - node_b_[id]).cwiseAbs());
        node_b_[id] = b;
        if (gathered_total != nullptr) (*gathered_total)[p] = pushed[i];
      } else {
        Rgb b = Rgb::Zero();
        for (int c = 0; c < 4; ++c) b += nodes[n.first_child + c].area_m2 * node_b_[n.first_child + c];
        node_b_[id] = b / n.area_m2;
      }
    }
  }
  return change;
}

RadiositySummary RadiositySolver::Solve(const std::vector<Rgb>& albedo, const std::vector<Rgb>& direct_irradiance,
                                        const std::vector<Rgb>& emission, RadiositySolution* solution) {
  RELUME_CHECK(solution != nullptr);
  const int n_patches = h_.LeafCount();
  CheckPerPatch(albedo, n_patches, "albedo", true);
  CheckPerPatch(direct_irradiance, n_patches, "direct irradiance", false);
  CheckPerPatch(emission, n_patches, "emission", false);
  const auto& nodes = h_.nodes();
  RadiositySummary summary;
  summary.patches = n_patches;
  const long long rays_before = caster_.rays_cast();
  const long long ff_before = form_factors_;

  std::vector<Rgb> leaf_b(n_patches);
  for (int p = 0; p < n_patches; ++p) leaf_b[p] = emission[p] + albedo[p].cwiseProduct(direct_irradiance[p]);
  double power_in = 0.0;
  for (int p = 0; p < n_patches; ++p) power_in += h_.leaf(p).area_m2 * Scalar(direct_irradiance[p] + emission[p]);
  summary.power_in = power_in;

  solution->radiosity.assign(n_patches, Rgb::Zero());
  solution->indirect_irradiance.assign(n_patches, Rgb::Zero());
  solution->form_factor_sum.assign(n_patches, 0.0);
  if (!(power_in > 0.0)) {
    summary.termination = RadiosityTermination::kNoLight;
    summary.converged = true;
    summary.reason = "no direct light and no emission: every radiosity is 0";
    summary.links = alive_links_;
    return summary;
  }
  std::fill(node_b_.begin(), node_b_.end(), Rgb::Zero());
  std::vector<Rgb> gathered(n_patches, Rgb::Zero());
  double previous = 0.0;
  int flat_count = 0;
  for (int pass = 0; pass < options_.refinement_passes; ++pass) {
    const auto t_refine = std::chrono::steady_clock::now();
    PullOracle(leaf_b, albedo);
    const size_t before = pairs_.size();
    if (!initial_linked_) {
      const auto& roots = h_.roots();
      for (size_t i = 0; i < roots.size(); ++i) {
        for (size_t j = i + 1; j < roots.size(); ++j) Refine(roots[i], roots[j], 0);
      }
      initial_linked_ = true;
    } else if (options_.hierarchical) {
      // Re-check every link against the oracle with the new radiosity; refine the failures.
      const size_t existing = pairs_.size();
      for (size_t i = 0; i < existing; ++i) {
        PairLink l = pairs_[i];
        if (!l.alive || budget_hit_) continue;
        const Node& a = nodes[l.p];
        const Node& b = nodes[l.q];
        if (a.IsLeaf() && b.IsLeaf()) continue;
        const double err =
            std::max(oracle_albedo_[l.p] * l.f_pq * oracle_b_[l.q], oracle_albedo_[l.q] * l.f_qp * oracle_b_[l.p]);
        if (err <= oracle_threshold_) continue;
        pairs_[i].alive = false;
        --alive_links_;
        const bool split_q = !b.IsLeaf() && (a.IsLeaf() || l.f_pq >= l.f_qp);
        for (int c = 0; c < 4; ++c) {
          split_q ? Refine(l.p, b.first_child + c, 1) : Refine(a.first_child + c, l.q, 1);
        }
      }
    }
    if (pass == 0 || pairs_.size() != before) CompileLinks();
    summary.refine_time_s += Seconds(t_refine);
    if (pass > 0 && pairs_.size() == before) break;  // nothing new to refine

    const auto t_solve = std::chrono::steady_clock::now();
    double total_b = 0.0;
    for (int it = 0; it < options_.max_iterations; ++it) {
      const double change = Sweep(albedo, direct_irradiance, emission, &gathered);
      total_b = 0.0;
      for (int p = 0; p < n_patches; ++p) total_b += h_.leaf(p).area_m2 * Scalar(node_b_[h_.leaves()[p]]);
      ++summary.iterations;
      const double residual = total_b > 0.0 ? change / total_b : 0.0;
      summary.contraction = previous > 0.0 ? residual / previous : 0.0;
      summary.residual = residual;
      previous = residual;
      // Converged when both the residual and the error it implies for the remaining sweeps
      // (residual * q / (1 - q), q the residual ratio) are within tolerance: with albedo near
      // 1 a small relative residual alone would stop far from the solution.
      const double q = summary.contraction;
      const double remaining = q < 1.0 ? residual * q / (1.0 - q) : INFINITY;
      if (it > 1 && residual <= options_.residual_tolerance && remaining <= options_.residual_tolerance) {
        summary.termination = RadiosityTermination::kConverged;
        break;
      }
      flat_count = summary.contraction >= 0.999 && it > 2 ? flat_count + 1 : 0;
      if (flat_count >= 5) {
        summary.termination = RadiosityTermination::kNotContracting;
        break;
      }
      summary.termination = RadiosityTermination::kMaxIterations;
    }
    summary.solve_time_s += Seconds(t_solve);
    for (int p = 0; p < n_patches; ++p) leaf_b[p] = node_b_[h_.leaves()[p]];
    if (summary.termination != RadiosityTermination::kConverged) break;
  }

  // Results, enclosure (form-factor sums) and energy balance.
  for (int p = 0; p < n_patches; ++p) {
    solution->radiosity[p] = leaf_b[p];
    solution->indirect_irradiance[p] = gathered[p];
    double f = 0.0;
    for (int id = h_.leaves()[p]; id >= 0; id = nodes[id].parent) {
      for (int k = in_offset_[id]; k < in_offset_[id + 1]; ++k) f += in_f_[k];
    }
    solution->form_factor_sum[p] = f;
    const double a = h_.leaf(p).area_m2;
    const Rgb h = direct_irradiance[p] + gathered[p];
    summary.power_absorbed += a * Scalar((Rgb::Ones() - albedo[p]).cwiseProduct(h));
    summary.power_escaped += a * Scalar(leaf_b[p]) * (1.0 - f);  // negative where sum_j F_ij > 1
  }
  summary.balance_error = (summary.power_in - summary.power_absorbed - summary.power_escaped) / summary.power_in;
  summary.converged = summary.termination == RadiosityTermination::kConverged;
  summary.estimated_error =
      summary.contraction < 1.0 ? summary.residual * summary.contraction / (1.0 - summary.contraction) : INFINITY;
  if (!std::isfinite(summary.estimated_error)) summary.estimated_error = 1e300;
  summary.links = alive_links_;
  summary.form_factors = form_factors_ - ff_before;
  summary.rays = caster_.rays_cast() - rays_before;
  summary.link_budget_exhausted = budget_hit_;
  std::ostringstream reason;
  switch (summary.termination) {
    case RadiosityTermination::kConverged:
      reason << "residual " << summary.residual << " and estimated error " << summary.estimated_error
             << " <= tolerance " << options_.residual_tolerance;
      break;
    case RadiosityTermination::kMaxIterations:
      reason << "stopped at max_iterations " << options_.max_iterations << " with residual " << summary.residual
             << " shrinking by " << summary.contraction << " per sweep, estimated error " << summary.estimated_error
             << " (albedo near 1 converges slowly); raise max_iterations or the tolerance";
      break;
    case RadiosityTermination::kNotContracting:
      reason << "residual no longer shrinks (ratio " << summary.contraction
             << "): the scene absorbs almost nothing (albedo 1 in a closed scene has no finite solution)";
      break;
    case RadiosityTermination::kNoLight: break;
  }
  if (budget_hit_) reason << "; link budget max_links reached, refinement stopped early (less accurate)";
  summary.reason = reason.str();
  return summary;
}

std::vector<Rgb> RadiositySolver::Gather(const std::vector<Rgb>& radiosity) const {
  RELUME_CHECK(static_cast<int>(radiosity.size()) == h_.LeafCount());
  RELUME_CHECK_MSG(!in_offset_.empty(), "RadiositySolver::Gather needs a Solve() first");
  const auto& nodes = h_.nodes();
  std::vector<Rgb> node_b(nodes.size(), Rgb::Zero());
  for (const auto& order : root_order_) {
    for (size_t i = order.size(); i-- > 0;) {
      const Node& n = nodes[order[i]];
      if (n.IsLeaf()) {
        node_b[order[i]] = radiosity[n.leaf];
      } else {
        Rgb b = Rgb::Zero();
        for (int c = 0; c < 4; ++c) b += nodes[n.first_child + c].area_m2 * node_b[n.first_child + c];
        node_b[order[i]] = b / n.area_m2;
      }
    }
  }
  std::vector<Rgb> out(h_.LeafCount(), Rgb::Zero());
  std::vector<Rgb> pushed;
  for (const auto& order : root_order_) {
    pushed.assign(order.size(), Rgb::Zero());
    int interior = 0;
    for (size_t i = 0; i < order.size(); ++i) {
      const int id = order[i];
      for (int k = in_offset_[id]; k < in_offset_[id + 1]; ++k) {
        pushed[i] += static_cast<double>(in_f_[k]) * node_b[in_source_[k]];
      }
      const Node& n = nodes[id];
      if (n.IsLeaf()) {
        out[n.leaf] = pushed[i];
      } else {
        const size_t first = 1 + 4 * static_cast<size_t>(interior++);
        for (int c = 0; c < 4; ++c) pushed[first + c] += pushed[i];
      }
    }
  }
  return out;
}

IndirectShareEstimate EstimateIndirectShare(const PatchHierarchy& hierarchy, const RayCaster& caster,
                                            const std::vector<Rgb>& albedo, const std::vector<Rgb>& direct_irradiance,
                                            double tolerance, int rays_per_form_factor) {
  CheckPerPatch(albedo, hierarchy.LeafCount(), "albedo", true);
  CheckPerPatch(direct_irradiance, hierarchy.LeafCount(), "direct irradiance", false);
  const auto& nodes = hierarchy.nodes();
  const auto& roots = hierarchy.roots();
  const size_t n = roots.size();
  std::vector<Rgb> rho(n), b0(n);
  std::vector<double> enclosure(n, 0.0);
  std::vector<Rgb> bounce(n, Rgb::Zero());
  for (size_t i = 0; i < n; ++i) {
    rho[i] = hierarchy.NodeMean(roots[i], albedo);
    const Rgb e = hierarchy.NodeMean(roots[i], direct_irradiance);
    b0[i] = rho[i].cwiseProduct(e);
  }
  // Root-to-root form factors, sampled on the smaller triangle, analytic over the larger one.
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = i + 1; j < n; ++j) {
      const Node& a0 = nodes[roots[i]];
      const Node& b0n = nodes[roots[j]];
      if (a0.root == b0n.root || !AnyInFront(a0, b0n) || !AnyInFront(b0n, a0)) continue;
      const bool i_small = a0.area_m2 <= b0n.area_m2;
      const Node& a = i_small ? a0 : b0n;
      const Node& b = i_small ? b0n : a0;
      double sum = 0.0;
      for (int k = 0; k < rays_per_form_factor; ++k) {
        const Eigen::Vector2d ua = Hammersley(k, rays_per_form_factor);
        const Eigen::Vector2d ub = Hammersley(k, rays_per_form_factor, kShiftU, kShiftV);
        const Eigen::Vector3d x = a.triangle.PointAt(ua.x(), ua.y());
        const double f = PointToTriangleFormFactor(x, a.normal, b.triangle);
        if (f > 0.0 && !caster.SegmentOccluded(x, a.normal, b.triangle.PointAt(ub.x(), ub.y()), b.normal)) sum += f;
      }
      const double f_ab = sum / rays_per_form_factor;
      const double f_ba = f_ab * a.area_m2 / b.area_m2;
      const double f_ij = i_small ? f_ab : f_ba;
      const double f_ji = i_small ? f_ba : f_ab;
      bounce[i] += f_ij * b0[j];
      bounce[j] += f_ji * b0[i];
      enclosure[i] += f_ij;
      enclosure[j] += f_ji;
    }
  }
  double direct_power = 0.0, bounce_power = 0.0, area = 0.0, rho_f = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const double a = nodes[roots[i]].area_m2;
    direct_power += a * Scalar(b0[i]);
    bounce_power += a * Scalar(rho[i].cwiseProduct(bounce[i]));
    rho_f += a * Scalar(rho[i]) * std::min(1.0, enclosure[i]);
    area += a;
  }
  IndirectShareEstimate out;
  out.first_bounce_ratio = direct_power > 0.0 ? bounce_power / direct_power : 0.0;
  double enclosed = 0.0;
  for (size_t i = 0; i < n; ++i) enclosed += nodes[roots[i]].area_m2 * std::min(1.0, enclosure[i]);
  out.mean_enclosure = area > 0.0 ? enclosed / area : 0.0;
  out.series_ratio = area > 0.0 ? std::min(rho_f / area, 0.999) : 0.0;
  out.indirect_share = out.first_bounce_ratio / (1.0 - out.series_ratio);
  out.skip = out.indirect_share < tolerance;
  std::ostringstream reason;
  reason << "estimated indirect share " << out.indirect_share << " (first bounce " << out.first_bounce_ratio
         << ", later bounces grow by " << out.series_ratio << ") " << (out.skip ? "<" : ">=") << " tolerance "
         << tolerance << (out.skip ? ": radiosity skipped, direct light only" : ": radiosity needed");
  out.reason = reason.str();
  return out;
}

}  // namespace relume::radiosity
