// Hierarchical radiosity (Hanrahan, Salzman and Aupperle 1991 style) over a PatchHierarchy.
//
// Equation, per patch i and channel: B_i = emission_i + albedo_i * (E_direct_i + sum_j F_ij B_j),
// where F_ij is the fraction of the power leaving i that reaches j (so sum_j F_ij <= 1) and
// E_direct is the direct irradiance from lights (direct_light.h). Interactions are links
// between quadtree nodes chosen by a BF oracle: a pair (p, q) is refined while
// albedo_p * F_pq(estimate) * B_q (or the same the other way) exceeds bf_epsilon times the
// scene's mean radiosity, and linked otherwise. A link stores both F_pq and F_qp
// (reciprocity: A_p F_pq = A_q F_qp), with visibility estimated by rays_per_form_factor rays.
// With hierarchical = false every pair of leaves is linked (n^2 form factors; small scenes).
//
// Solver: block Gauss-Seidel over mesh triangles (gather over links, push irradiance down to
// the patches, pull radiosity up), stopped when the relative residual (area-weighted L1 change
// of B in one sweep over area-weighted L1 of B) and the error it implies for the remaining
// sweeps (residual * q / (1 - q), q the observed residual ratio) are both at most
// residual_tolerance. Links persist
// between Solve() calls and are refined further when a new lighting needs it.
#pragma once

#include <string>
#include <vector>

#include "processing/radiosity/geometry.h"
#include "processing/radiosity/hierarchy.h"

namespace relume::radiosity {

struct RadiosityOptions {
  bool hierarchical = true;
  double bf_epsilon = 2e-3;      // link refinement threshold, relative to mean radiosity
  int rays_per_form_factor = 4;  // sample points (and visibility rays) per link
  int refinement_passes = 2;     // refine, solve, refine again with the new radiosity, ...
  double residual_tolerance = 0.01;
  int max_iterations = 500;
  long long max_links = 50'000'000;  // memory guard: refinement stops here and says so
  bool IsValid(std::string* why) const;
};

enum class RadiosityTermination {
  kConverged,       // residual <= residual_tolerance
  kNoLight,         // nothing emits or is lit: B = 0 exactly
  kMaxIterations,   // stopped at max_iterations (slow convergence, e.g. albedo near 1)
  kNotContracting,  // residual stopped shrinking (albedo 1 in a closed scene: no absorption)
};
const char* ToString(RadiosityTermination termination);

struct RadiositySummary {
  RadiosityTermination termination = RadiosityTermination::kMaxIterations;
  bool converged = false;
  std::string reason;
  int iterations = 0;
  double residual = 0.0;         // relative, see header comment
  double contraction = 0.0;      // last residual ratio (spectral radius estimate)
  double estimated_error = 0.0;  // residual * contraction / (1 - contraction), relative
  long long links = 0;           // links alive after refinement
  long long form_factors = 0;    // form factors computed in this Solve (pairs)
  long long rays = 0;            // visibility rays cast in this Solve
  bool link_budget_exhausted = false;
  // Energy balance (scalar = mean of R, G, B; W, or relative units times m^2):
  double power_in = 0.0;        // direct irradiance + self-emission, integrated over area
  double power_absorbed = 0.0;  // sum of area * (1 - albedo) * total irradiance
  double power_escaped = 0.0;   // net, leaving the scene: area * B * (1 - sum_j F_ij)
  double balance_error = 0.0;   // (in - absorbed - escaped) / in
  double refine_time_s = 0.0;
  double solve_time_s = 0.0;
  int patches = 0;
  std::string BriefReport() const;
};

struct RadiositySolution {
  std::vector<Rgb> radiosity;            // B per patch, W m^-2
  std::vector<Rgb> indirect_irradiance;  // sum_j F_ij B_j per patch, W m^-2
  std::vector<double> form_factor_sum;   // sum_j F_ij per patch (enclosure; 1 in a closed room)
};

class RadiositySolver {
 public:
  // The hierarchy and caster must outlive the solver. Throws InvalidArgumentError for bad
  // options.
  RadiositySolver(const PatchHierarchy& hierarchy, const RayCaster& caster, const RadiosityOptions& options);

  // Per-patch albedo (in [0, 1]), direct irradiance and self-emission (radiosity). Throws
  // InvalidArgumentError when sizes differ or values are negative or non-finite.
  RadiositySummary Solve(const std::vector<Rgb>& albedo, const std::vector<Rgb>& direct_irradiance,
                         const std::vector<Rgb>& emission, RadiositySolution* solution);

  // Indirect irradiance sum_j F_ij B_j per patch for given per-patch radiosity, over the links
  // the last Solve() refined (call Solve() first).
  std::vector<Rgb> Gather(const std::vector<Rgb>& radiosity) const;

  long long link_count() const { return alive_links_; }

 private:
  struct PairLink {
    int p, q;
    float f_pq, f_qp;
    bool alive;
  };
  void Refine(int p, int q, int depth);
  void ComputeLink(int p, int q);
  bool Interacts(int p, int q) const;
  void CompileLinks();
  void PullOracle(const std::vector<Rgb>& leaf_b, const std::vector<Rgb>& albedo);
  double Sweep(const std::vector<Rgb>& albedo, const std::vector<Rgb>& direct, const std::vector<Rgb>& emission,
               std::vector<Rgb>* gathered_total);

  const PatchHierarchy& h_;
  const RayCaster& caster_;
  RadiosityOptions options_;
  std::vector<PairLink> pairs_;
  long long alive_links_ = 0;
  long long form_factors_ = 0;
  bool budget_hit_ = false;
  bool initial_linked_ = false;
  // Oracle state per node: scalar radiosity and albedo.
  std::vector<double> oracle_b_, oracle_albedo_;
  double oracle_threshold_ = 0.0;
  // Incoming links per node (CSR) and radiosity per node.
  std::vector<int> in_offset_, in_source_;
  std::vector<float> in_f_;
  std::vector<Rgb> node_b_;
  std::vector<std::vector<int>> root_order_;  // nodes of each root, parents before children
};

// Cheap first look at how much indirect light a scene has (for skipping radiosity): links
// between mesh triangles only (a few rays each), one bounce of the direct light.
struct IndirectShareEstimate {
  double first_bounce_ratio = 0.0;  // reflected power of bounce 1 / reflected direct power
  double series_ratio = 0.0;        // mean albedo * mean enclosure (growth of later bounces)
  double indirect_share = 0.0;      // estimated indirect / direct reflected power, all bounces
  double mean_enclosure = 0.0;      // area-weighted mean of sum_j F_ij over mesh triangles
  bool skip = false;                // indirect_share < tolerance
  std::string reason;
};
IndirectShareEstimate EstimateIndirectShare(const PatchHierarchy& hierarchy, const RayCaster& caster,
                                            const std::vector<Rgb>& albedo, const std::vector<Rgb>& direct_irradiance,
                                            double tolerance, int rays_per_form_factor = 4);

}  // namespace relume::radiosity
