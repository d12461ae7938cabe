// Irradiance ratio maps (Troccoli & Allen, "Relighting Acquired Models of Outdoor Scenes"):
// relighting a photograph of a diffuse outdoor scene to the illumination of another one,
// with per-normal ratios of target to source irradiance, R(n) = E_target(n) / E_source(n),
// learnt where the two photographs overlap.
//
// Conventions:
//  - Normals are unit vectors in the mesh frame (ENU, or a UTM grid frame: the sun directions
//    given must be in the same frame, see core/frames.h).
//  - Ratios are target / source, per linear RGB channel: relit = source radiance x R.
//  - Shadow state is the visible fraction f of the sun's disk (0 = umbra, 1 = fully lit).
//    A sample with f >= lit_threshold counts as lit, f <= shadow_threshold as shadowed; the
//    penumbra between is not used for learning, only for relighting.
//  - Normal bins: the octahedral map of the sphere onto a bins x bins square (Cigolle et al.
//    2014): continuous, nearly equal-area, every bin used. `bins` is the resolution knob.
//
// Beyond the paper:
//  - The four maps are tied together by a sun + sky model per channel:
//      E_source(n, f_s, v) = S_s f_s max(0, n . sun_s) + K_s v
//      E_target(n, f_t, v) = S_t f_t max(0, n . sun_t) + K_t v
//    where v is the surface's sky view: (1/pi) times the integral of max(0, n . w) over the
//    directions w above the horizon that no geometry blocks, so the irradiance a uniform sky
//    of radiance 1/pi gives it (1 on open flat ground, (1 + n_z) / 2 on an open tilted plane,
//    about 1/2 on the ground at the foot of a tall wall). When a sample's v is not known,
//    the open-plane value (1 + n_z) / 2 stands for it. Fitted by linear least squares to every
//    sample with K_s = 1. In cast shadow only the sky lights a surface, so a lit-to-shadow
//    ratio falls with v (a wall's foot darkens more than open ground): the per-normal maps
//    cannot hold that, the model's v can (RatioMap::mean_sky_view, IrmSet::Ratio). It fills bins no sample reached and,
//    in the penumbra, gives R(n, f_s, f_t) from the four maps exactly:
//      R = [f_t (R_sl / R_ss - 1) + 1] / [f_s (1 / R_ls - 1 / R_ss) + 1 / R_ss]
//    where R_xy is the map from source state x to target state y (l = lit, s = shadow).
//  - A sky brighter at the horizon than at the zenith (or darker) weighs directions unequally:
//    with the sky's shape L(w) = a (1 + g w_z) measured in each photograph (sky_shape.h), the
//    sky term v becomes v + g_s m in the source and v + g_t m in the target, m the surface's
//    zenith moment (SkyViewMoments: (1/pi) times the integral of w_z max(0, n . w) over the
//    same unblocked directions). g = 0, or m unknown (NaN), is the uniform sky above.
//  - Light reflected by the other surfaces (interreflection, indirect.h): each sample may carry
//    I_s and I_t, the irradiance its neighbours send it in each photograph, gathered from the
//    radiance the photographs show (so in the photographs' units, not the model's). The model
//    then reads
//      E_source = S_s f_s max(0, n . sun_s) + (v + g_s m) + q I_s
//      E_target = S_t f_t max(0, n . sun_t) + K_t (v + g_t m) + q I_t
//    with q per channel, the photographs' units in the model's (K_s = 1), fitted with the rest:
//    the ratio's equation stays linear in (S_s, S_t, K_t, q). Without indirect light q = 0 and
//    the model is the one above (issue 26: on a courtyard rendered with 4 bounces the ground in
//    a wall's shadow gets a third of its light from the sunlit walls).
//  - Empty bins can instead be filled by a Gaussian kernel over the sphere (Beauchesne & Roy).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <vector>

namespace relume::irm {

enum class MapKind { kLitToLit = 0, kShadowToShadow = 1, kLitToShadow = 2, kShadowToLit = 3 };
const char* ToString(MapKind kind);

enum class FillMethod { kNone, kSmoothing, kSunSkyModel };
const char* ToString(FillMethod method);

struct IrmOptions {
  int bins = 32;                      // per side of the octahedral square
  float lit_threshold = 0.99f;        // sun fraction at or above: lit
  float shadow_threshold = 0.01f;     // at or below: shadowed
  int min_samples_per_bin = 2;        // fewer: the bin counts as empty
  float trim_fraction = 0.2f;         // robust mean: drop this share at each end
  float min_source_radiance = 1e-6f;  // smaller source radiance gives no ratio (no division by ~0)
  FillMethod fill = FillMethod::kSunSkyModel;
  // A measured bin's ratio is what its samples' normals saw; a pixel's normal elsewhere in the
  // bin (near the terminator, on curved surfaces) gets it times model(n) / model(bin's mean
  // normal) when the sun + sky model is valid: the maps keep what the model misses, the model
  // carries the variation inside a bin (beyond the paper).
  bool model_correction = true;
  // One map (lit to lit) when no sample is in cast shadow in either photograph: the planner's
  // skip. false fills all four maps anyway (how `relume bench --stage planner` times the skip).
  bool single_map_without_shadow = true;
  float smoothing_sigma_rad = 0.2f;  // kSmoothing kernel width
  bool IsValid(std::string* why) const;
};

// One vertex seen in both photographs.
struct Sample {
  Eigen::Vector3f normal;
  Eigen::Vector3f source_rgb;  // linear radiance
  Eigen::Vector3f target_rgb;
  float source_sun = 1.0f;  // visible sun fraction when each photograph was taken
  float target_sun = 1.0f;
  float sky_view = std::numeric_limits<float>::quiet_NaN();    // v (top of this file); NaN: unknown
  float sky_moment = std::numeric_limits<float>::quiet_NaN();  // m (top of this file); NaN: unknown
  // I_s, I_t (top of this file): irradiance from the other surfaces in each photograph, in the
  // photographs' radiance units times pi. Zero: none, or not gathered.
  Eigen::Vector3f source_indirect = Eigen::Vector3f::Zero();
  Eigen::Vector3f target_indirect = Eigen::Vector3f::Zero();
};

Eigen::Vector2f OctahedralFromDirection(const Eigen::Vector3f& n);  // unit vector -> [0, 1]^2
Eigen::Vector3f DirectionFromOctahedral(const Eigen::Vector2f& uv);

struct RatioMap {
  int bins = 0;
  std::vector<Eigen::Vector3f> ratio;        // bins * bins; NaN where empty
  std::vector<int> count;                    // samples per bin
  std::vector<std::uint8_t> source;          // 0 empty, 1 measured, 2 smoothing, 3 model
  std::vector<Eigen::Vector3f> mean_normal;  // measured: mean sample normal; model: bin centre; else NaN
  std::vector<float> mean_sky_view;          // measured: mean sample sky view (NaN: unknown, open plane)
  std::vector<float> mean_sky_moment;        // measured: mean sample zenith moment (NaN: unknown, uniform sky)
  // What the model correction divides by: for a measured bin, the sun + sky model's ratio at
  // each of the bin's samples (their normals, sky views and moments, the map's pure sun
  // states), averaged as the bin's ratio is (trimmed mean); for a model-filled bin, the model at
  // its centre. NaN: no correction for this bin (no valid model, smoothing fill, empty).
  std::vector<Eigen::Vector3f> model_ratio;
  int BinOf(const Eigen::Vector3f& normal) const;
  int measured_bins() const;
  // Bilinear interpolation between the centres of the four nearest bins that hold a value
  // (weights renormalised over those); NaN when none does.
  Eigen::Vector3f Interpolate(const Eigen::Vector3f& normal) const;
  // The same, each bin's value times correction(bin index) where the bin has a finite
  // model_ratio and the correction is finite.
  template <typename Correction>
  Eigen::Vector3f Interpolate(const Eigen::Vector3f& normal, const Correction& correction) const;
};

// Per-channel sun + sky model of source and target irradiance (see the top of this file).
struct SunSkyModel {
  bool valid = false;
  Eigen::Vector3f sun_source = Eigen::Vector3f::Zero();  // S_s (K_s = 1)
  Eigen::Vector3f sun_target = Eigen::Vector3f::Zero();  // S_t
  Eigen::Vector3f sky_target = Eigen::Vector3f::Zero();  // K_t
  Eigen::Vector3f sun_dir_source = Eigen::Vector3f::UnitZ();
  Eigen::Vector3f sun_dir_target = Eigen::Vector3f::UnitZ();
  // The sky's shape in each photograph, g per channel (sky_shape.h; 0: uniform). Inputs of the
  // fit, not fitted.
  Eigen::Vector3f sky_gradient_source = Eigen::Vector3f::Zero();
  Eigen::Vector3f sky_gradient_target = Eigen::Vector3f::Zero();
  // q (top of this file): indirect irradiance in the photographs' units to the model's. Zero
  // when the samples carried none or the fit could not separate it (then `indirect_reason`).
  Eigen::Vector3f indirect_scale = Eigen::Vector3f::Zero();
  std::string indirect_reason;
  double rms_relative_residual = 0.0;  // of the fitted ratios
  double rms_ratio_error = 0.0;        // the model's ratio against the rows', relative (any kind of fit)
  double condition_number = 0.0;       // of the weighted least-squares system (worst channel)
  std::string reason;                  // why invalid, when it is
  // `sky_view` NaN: the open-plane value (1 + n_z) / 2; `sky_moment` NaN (or sky_view NaN):
  // the sky taken as uniform. `indirect_*`: I_s and I_t (Sample); zero: none.
  Eigen::Vector3f Ratio(const Eigen::Vector3f& normal, float source_sun, float target_sun,
                        float sky_view = std::numeric_limits<float>::quiet_NaN(),
                        float sky_moment = std::numeric_limits<float>::quiet_NaN(),
                        const Eigen::Vector3f& indirect_source = Eigen::Vector3f::Zero(),
                        const Eigen::Vector3f& indirect_target = Eigen::Vector3f::Zero()) const;
  // The model's irradiance of each photograph (its units: K_s = 1) for the same arguments,
  // per channel; the indirect term alone in *indirect_source / *indirect_target when given.
  void Irradiance(const Eigen::Vector3f& normal, float source_sun, float target_sun, float sky_view, float sky_moment,
                  const Eigen::Vector3f& indirect_source, const Eigen::Vector3f& indirect_target,
                  Eigen::Vector3f* source, Eigen::Vector3f* target) const;
};

// How much of the light the samples receive comes from the other surfaces, by the fitted model:
// the mean of q I / E per region of each photograph (lit: the sun's disk fully visible and the
// surface facing it; shadow: cast or attached shadow), over the samples used.
struct IndirectShare {
  double source_lit = 0.0, source_shadow = 0.0, target_lit = 0.0, target_shadow = 0.0;
  int source_lit_samples = 0, source_shadow_samples = 0, target_lit_samples = 0, target_shadow_samples = 0;
};

struct IrmSet {
  std::array<RatioMap, 4> maps;  // indexed by MapKind
  SunSkyModel model;
  bool single_map = false;  // no sample in cast shadow in either photograph
  int samples_used = 0;
  int samples_in_penumbra = 0;  // skipped for learning
  int samples_too_dark = 0;     // source radiance below min_source_radiance
  std::string summary;          // what was built and why
  float lit_threshold = 0.99f;  // copied from the options that built the set
  float shadow_threshold = 0.01f;
  bool model_correction = true;
  // Interreflection (indirect.h): I_s and I_t per mesh vertex (photograph units, Sample), what
  // a relit pixel interpolates; empty when not gathered. The share of each region's light that
  // is indirect, by the model.
  std::vector<Eigen::Vector3f> vertex_indirect_source, vertex_indirect_target;
  // The per-vertex radiance the indirect light was gathered from (each photograph's, the
  // model's where it does not see a vertex): what a pixel's own gather reads (relight.h).
  std::vector<Eigen::Vector3f> vertex_radiance_source, vertex_radiance_target;
  IndirectShare indirect_share;
  // The ratio for a normal, the two sun fractions (penumbrae interpolate exactly between maps)
  // and the surface's sky view (with model_correction, a bin's ratio is carried from its
  // samples' mean sky view to this one; NaN: unknown), zenith moment (NaN: a uniform sky) and
  // indirect irradiance (zero: none). NaN when nothing covers that normal.
  Eigen::Vector3f Ratio(const Eigen::Vector3f& normal, float source_sun, float target_sun,
                        float sky_view = std::numeric_limits<float>::quiet_NaN(),
                        float sky_moment = std::numeric_limits<float>::quiet_NaN(),
                        const Eigen::Vector3f& indirect_source = Eigen::Vector3f::Zero(),
                        const Eigen::Vector3f& indirect_target = Eigen::Vector3f::Zero()) const;
};

// IrmSet::Ratio for many lookups (every pixel of a photograph). What depends on a bin only is
// baked once per map (which bins hold a value, which are measured, and with model_correction
// the bin's ratio divided by the model at the bin's mean normal and sky view); what depends on
// the normal only (its four bins and their weights in every map, its cosines to the suns) is
// prepared once per normal (NormalTerms: RelightPixels keeps them per flat normal, for every
// pixel of the triangles that share it); what is left per lookup is one model evaluation per
// map read. IrmSet::Ratio evaluates the model five
// times per map and redoes the bins each time. Equal to IrmSet::Ratio up to float rounding (the
// correction's product is regrouped: sum_b w_b ratio_b model(n) / model(b) becomes
// model(n) sum_b (w_b / w) (ratio_b / model(b))). Keeps a pointer to `set`, which must outlive it.
class RatioTable {
 public:
  explicit RatioTable(const IrmSet& set);

  // One map's interpolated value for a normal: fixed + model(n) x corrected where the model
  // correction applies and the model at the normal is finite, else plain. (RGB and a fourth
  // lane of zeros, for 4-wide vector arithmetic.)
  struct MapTerms {
    Eigen::Array4f plain = Eigen::Array4f::Zero();      // every bin used, uncorrected, over the weight
    Eigen::Array4f fixed = Eigen::Array4f::Zero();      // the bins without a correction, over the weight
    Eigen::Array4f corrected = Eigen::Array4f::Zero();  // sum of w_b ratio_b / model(b), over the weight
    bool any = false;                                   // some bin around the normal holds a value
  };
  struct NormalTerms {
    float cos_source = 0.0f, cos_target = 0.0f;  // max(0, n . sun) for each photograph's sun
    float open_sky = 0.0f;                       // (1 + n_z) / 2: the sky view when it is unknown
    std::array<MapTerms, 4> maps;                // indexed by MapKind
  };
  NormalTerms Prepare(const Eigen::Vector3f& normal) const;
  Eigen::Vector3f Ratio(const NormalTerms& terms, float source_sun, float target_sun, float sky_view,
                        float sky_moment = std::numeric_limits<float>::quiet_NaN(),
                        const Eigen::Vector3f& indirect_source = Eigen::Vector3f::Zero(),
                        const Eigen::Vector3f& indirect_target = Eigen::Vector3f::Zero()) const;
  Eigen::Vector3f Ratio(const Eigen::Vector3f& normal, float source_sun, float target_sun,
                        float sky_view = std::numeric_limits<float>::quiet_NaN(),
                        float sky_moment = std::numeric_limits<float>::quiet_NaN(),
                        const Eigen::Vector3f& indirect_source = Eigen::Vector3f::Zero(),
                        const Eigen::Vector3f& indirect_target = Eigen::Vector3f::Zero()) const {
    return Ratio(Prepare(normal), source_sun, target_sun, sky_view, sky_moment, indirect_source, indirect_target);
  }

 private:
  enum BinFlags : std::uint8_t { kFinite = 1, kMeasured = 2, kCorrected = 4 };
  struct Bin {  // RGB and a fourth lane of zeros
    Eigen::Array4f ratio = Eigen::Array4f::Zero();
    Eigen::Array4f ratio_over_model = Eigen::Array4f::Zero();  // kCorrected: ratio / model(bin)
    std::uint8_t flags = 0;
  };

  // SunSkyModel::Ratio from the normal's terms, the three channels in one vector division
  // (the fourth lane is meaningless).
  Eigen::Array4f ModelRatio(const NormalTerms& terms, float source_sun, float target_sun, float sky_view,
                            float sky_moment, const Eigen::Array4f& indirect_source,
                            const Eigen::Array4f& indirect_target) const;

  const IrmSet* set_;
  int bins_ = 0;
  bool correct_ = false;                  // model_correction with a valid model
  std::array<std::vector<Bin>, 4> maps_;  // indexed by MapKind
  // The model's coefficients per channel, a fourth lane of zeros for the vector arithmetic.
  Eigen::Array4f sky_gradient_source_ = Eigen::Array4f::Zero(), sky_gradient_target_ = Eigen::Array4f::Zero();
  Eigen::Array4f sun_source_ = Eigen::Array4f::Zero(), sun_target_ = Eigen::Array4f::Zero(),
                 sky_target_ = Eigen::Array4f::Zero(), indirect_scale_ = Eigen::Array4f::Zero();
};

// `sky_gradient_*`: the sky's shape g in each photograph (sky_shape.h; zero: uniform), used
// with the samples' zenith moments. Samples with indirect light (Sample::source_indirect,
// target_indirect) fit the model with it, to the samples: `*_sky_radiance` are the photographs'
// sky radiances at the horizon (SkyShape::horizon, each photograph's units; zero: not
// measured). With both, K_t = a_t / a_s and q = 1 / (pi a_s) are known and only the suns are
// fitted; with the source's alone q is known and K_t fitted; with the target's alone q =
// K_t / (pi a_t) follows the fitted K_t; without either K_t and q are fitted. Without a valid fit the
// model is fitted without indirect light and SunSkyModel::indirect_reason says why; when that free fit fails too and
// both sky radiances are given, the suns are fitted with the measured K_t.
IrmSet BuildIrms(std::span<const Sample> samples, const Eigen::Vector3f& sun_dir_source,
                 const Eigen::Vector3f& sun_dir_target, const IrmOptions& options,
                 const Eigen::Vector3f& sky_gradient_source = Eigen::Vector3f::Zero(),
                 const Eigen::Vector3f& sky_gradient_target = Eigen::Vector3f::Zero(),
                 const Eigen::Vector3f& source_sky_radiance = Eigen::Vector3f::Zero(),
                 const Eigen::Vector3f& target_sky_radiance = Eigen::Vector3f::Zero());

}  // namespace relume::irm
