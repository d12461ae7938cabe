// The per-pixel stage of IRM relighting written as plainly as its definition (docs/irm.md,
// "Method" 6): each pixel's camera ray, its interpolated normal, sun fractions and sky view, its
// own sun rays where a shadow edge crosses its triangle or a vertex has no fraction, its own sky
// rays where a vertex has no sky view or (exact_shadow_edges) the vertices' sky views span more
// than kSkyViewEdgeSpread, and
// IrmSet::Ratio. Test code only: RelightPixels must give the same images up to float rounding
// (it bakes the IRMs into a RatioTable, traces rays in packets and writes each pixel once).
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

#include "processing/irm/relight.h"

namespace relume::irm::testing {

inline RelightResult RelightPixelsByDefinition(const RayCaster& caster, const View& source, const View& target,
                                               const ViewGeometry& source_geometry, const ViewGeometry& target_geometry,
                                               const IrmSet& irms, const RelightOptions& options) {
  const TriangleMesh& mesh = caster.mesh();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const int width = source.image->width(), height = source.image->height();
  RelightResult result;
  result.relit.pixels = source.image->pixels.clone();
  result.status = cv::Mat(height, width, CV_8UC1, cv::Scalar(kNoGeometry));
  result.source_sun = cv::Mat(height, width, CV_32FC1, cv::Scalar(nan));
  result.target_sun = result.source_sun.clone();
  auto own_fraction = [&](const Eigen::Vector3f& point, const Eigen::Vector3f& normal, const Eigen::Vector3f& sun) {
    const Eigen::Vector3f s = sun.normalized();
    if (normal.dot(s) <= 0.0f) return 1.0f;  // attached shadow
    return SunVisibleFraction(caster, point, normal, s, options.sun_angular_radius_rad, options.sun_samples);
  };
  auto mixed = [&](const std::vector<float>& f, const Eigen::Vector3i& tri) {
    const float a = f[static_cast<std::size_t>(tri[0])], b = f[static_cast<std::size_t>(tri[1])],
                c = f[static_cast<std::size_t>(tri[2])];
    return std::max({a, b, c}) - std::min({a, b, c}) > 1e-3f;
  };
  std::vector<RayCaster::Hit> hits(static_cast<std::size_t>(width));
  for (int y = 0; y < height; ++y) {
    caster.IntersectCameraRow(source.camera, y, 0, width, hits);
    for (int x = 0; x < width; ++x) {
      const RayCaster::Hit& hit = hits[static_cast<std::size_t>(x)];
      if (!hit.valid) continue;
      if (!source.mask.empty() && source.mask.at<std::uint8_t>(y, x) != 0) {
        result.status.at<std::uint8_t>(y, x) = kMasked;
        continue;
      }
      const Eigen::Vector3f normal = caster.Interpolate(mesh.normals, hit).normalized();
      const Eigen::Vector3f point = caster.Interpolate(mesh.positions, hit);
      float fs = caster.Interpolate(source_geometry.sun_fraction, hit);
      float ft = caster.Interpolate(target_geometry.sun_fraction, hit);
      const Eigen::Vector3i& tri = mesh.triangles[static_cast<std::size_t>(hit.triangle)];
      const bool no_vertex_value = std::isnan(fs) || std::isnan(ft);
      const bool own_source =
          no_vertex_value || (options.exact_shadow_edges && mixed(source_geometry.sun_fraction, tri));
      const bool own_target =
          no_vertex_value || (options.exact_shadow_edges && mixed(target_geometry.sun_fraction, tri));
      if (own_source) fs = own_fraction(point, normal, source.sun_dir);
      if (own_target) ft = own_fraction(point, normal, target.sun_dir);
      if ((own_source || own_target) && !options.use_penumbra_fractions) {
        fs = fs >= 0.5f ? 1.0f : 0.0f;
        ft = ft >= 0.5f ? 1.0f : 0.0f;
      }
      result.source_sun.at<float>(y, x) = fs;
      result.target_sun.at<float>(y, x) = ft;
      float sky = nan, moment = nan;
      if (!source_geometry.sky_view.empty()) {
        sky = caster.Interpolate(source_geometry.sky_view, hit);
        if (!source_geometry.sky_moment.empty()) moment = caster.Interpolate(source_geometry.sky_moment, hit);
        const auto& v = source_geometry.sky_view;
        const float v0 = v[static_cast<std::size_t>(tri[0])], v1 = v[static_cast<std::size_t>(tri[1])],
                    v2 = v[static_cast<std::size_t>(tri[2])];
        const bool sky_edge =
            options.exact_shadow_edges && std::max({v0, v1, v2}) - std::min({v0, v1, v2}) > kSkyViewEdgeSpread;
        if (std::isnan(sky) || sky_edge) {
          const SkyView own = SkyViewMoments(caster, point, normal, options.sky_samples);
          sky = own.view;
          if (!source_geometry.sky_moment.empty()) moment = own.zenith_moment;
        }
      }
      const Eigen::Vector3f ratio = irms.Ratio(normal, fs, ft, sky, moment);
      if (!ratio.allFinite()) {
        result.status.at<std::uint8_t>(y, x) = kNoRatio;
        continue;
      }
      cv::Vec3f& out = result.relit.pixels.at<cv::Vec3f>(y, x);
      for (int c = 0; c < 3; ++c) out[c] *= ratio[c];
      result.status.at<std::uint8_t>(y, x) = kRelit;
    }
  }
  return result;
}

// How far two relightings of one photograph differ, pixel by pixel.
struct RelightDifference {
  std::int64_t status_differs = 0;    // pixels with another PixelStatus
  std::int64_t fraction_differs = 0;  // pixels whose sun fractions differ by more than 1e-6 (or in NaN-ness)
  double max_relative = 0.0;          // largest |a - b| / |b| over the relit pixels' channels
};

inline RelightDifference CompareRelightings(const RelightResult& a, const RelightResult& b) {
  RelightDifference d;
  auto fraction_differs = [](float u, float v) {
    return std::isnan(u) != std::isnan(v) || (!std::isnan(u) && std::abs(u - v) > 1e-6f);
  };
  for (int y = 0; y < b.status.rows; ++y) {
    for (int x = 0; x < b.status.cols; ++x) {
      const std::uint8_t status = b.status.at<std::uint8_t>(y, x);
      d.status_differs += a.status.at<std::uint8_t>(y, x) != status;
      d.fraction_differs += fraction_differs(a.source_sun.at<float>(y, x), b.source_sun.at<float>(y, x)) ||
                            fraction_differs(a.target_sun.at<float>(y, x), b.target_sun.at<float>(y, x));
      const cv::Vec3f p = a.relit.pixels.at<cv::Vec3f>(y, x), q = b.relit.pixels.at<cv::Vec3f>(y, x);
      for (int c = 0; c < 3; ++c) {
        if (p[c] == q[c] || (std::isnan(p[c]) && std::isnan(q[c]))) continue;
        // Pixels left untouched must be the source's bits; relit ones finite in both.
        if (status != kRelit || !std::isfinite(p[c]) || !std::isfinite(q[c])) {
          d.max_relative = std::numeric_limits<double>::infinity();
          continue;
        }
        const double scale = std::max(std::abs(static_cast<double>(q[c])), 1e-30);
        d.max_relative = std::max(d.max_relative, std::abs(static_cast<double>(p[c]) - q[c]) / scale);
      }
    }
  }
  return d;
}

}  // namespace relume::irm::testing
