#include "calibration/calibration_profile.h"

#include <cmath>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/error.h"
#include "core/input_file.h"

namespace relume::calibration {
namespace {

using nlohmann::json;

bool Fail(std::string* why, const std::string& reason) {
  if (why) *why = reason;
  return false;
}

template <typename T>
T Require(const json& j, const std::string& key, const std::string& path) {
  if (!j.contains(key)) throw ConfigError(path, 0, key, "missing");
  try {
    return j.at(key).get<T>();
  } catch (const json::exception& e) {
    throw ConfigError(path, 0, key, std::string("malformed: ") + e.what());
  }
}

// Per-channel lookup: gain then CCM, on linear values.
void CorrectPixels(const CalibrationProfile& profile, cv::Mat& rgb) {
  const Eigen::Matrix3f m = profile.ccm.cast<float>();
  for (int y = 0; y < rgb.rows; ++y) {
    auto* row = rgb.ptr<cv::Vec3f>(y);
    for (int x = 0; x < rgb.cols; ++x) {
      Eigen::Vector3f g;
      for (int c = 0; c < 3; ++c) g[c] = static_cast<float>(profile.gain.Apply(c, row[x][c]));
      const Eigen::Vector3f out = m * g;
      row[x] = cv::Vec3f(out[0], out[1], out[2]);
    }
  }
}

}  // namespace

bool CalibrationProfile::IsValid(std::string* why) const {
  if (gain_input != "radiance" && gain_input != "normalized_code") {
    return Fail(why, "gain_input must be 'radiance' or 'normalized_code'");
  }
  if (response && !response->IsValid(why)) return false;
  if (!ccm.allFinite()) return Fail(why, "the colour matrix is not finite");
  for (int c = 0; c < 3; ++c) {
    if (gain.x[c].size() != gain.y[c].size()) return Fail(why, "gain knots x and y differ in length");
    if (gain.x[c].size() == 1) return Fail(why, "a gain needs 0 or at least 2 knots");
    for (std::size_t i = 1; i < gain.x[c].size(); ++i) {
      if (!(gain.x[c][i] > gain.x[c][i - 1])) return Fail(why, "gain knots must be strictly ascending");
    }
  }
  return true;
}

std::string ProfileToJson(const CalibrationProfile& profile) {
  json j;
  j["format"] = "relume-calibration-profile";
  j["version"] = 1;
  j["camera"] = profile.camera;
  j["gain_input"] = profile.gain_input;
  if (profile.response) {
    j["response"] = {{"levels", profile.response->levels},
                     {"sensor_linear", profile.response->sensor_linear},
                     {"inverse", profile.response->inverse}};
  } else {
    j["response"] = nullptr;
  }
  j["gain"] = json::array();
  for (int c = 0; c < 3; ++c) j["gain"].push_back({{"x", profile.gain.x[c]}, {"y", profile.gain.y[c]}});
  j["ccm"] = json::array();
  for (int r = 0; r < 3; ++r) j["ccm"].push_back({profile.ccm(r, 0), profile.ccm(r, 1), profile.ccm(r, 2)});
  j["fit"] = {{"usable", profile.fit.usable},
              {"low_confidence", profile.fit.low_confidence},
              {"patches_used", profile.fit.patches_used},
              {"condition", profile.fit.condition},
              {"mean_delta_e_2000", profile.fit.mean_delta_e},
              {"max_delta_e_2000", profile.fit.max_delta_e},
              {"reason", profile.fit.reason}};
  if (!profile.fit.patch_delta_e.empty()) {
    json per_patch = json::array();  // null for a patch the fit did not use
    for (double de : profile.fit.patch_delta_e) per_patch.push_back(std::isfinite(de) ? json(de) : json());
    j["fit"]["patch_delta_e_2000"] = per_patch;
  }
  return j.dump(1) + "\n";
}

void SaveProfile(const CalibrationProfile& profile, const std::string& path) {
  const std::string text = ProfileToJson(profile);
  std::ofstream out(path);
  if (!out) throw IoError(path, "cannot be written");
  out << text;
  if (!out) throw IoError(path, "write failed (disk full?)");
}

CalibrationProfile LoadProfile(const std::string& path) {
  return ProfileFromJson(ReadInputFile(path), path);
}

CalibrationProfile ProfileFromJson(const std::string& text, const std::string& path) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::exception& e) {
    throw ConfigError(path, 0, "", std::string("not valid JSON: ") + e.what());
  }
  if (!j.is_object() || Require<std::string>(j, "format", path) != "relume-calibration-profile") {
    throw ConfigError(path, 0, "format", "not a relume calibration profile");
  }
  if (Require<int>(j, "version", path) != 1) throw ConfigError(path, 0, "version", "only version 1 is known");
  CalibrationProfile p;
  p.camera = Require<std::string>(j, "camera", path);
  p.gain_input = Require<std::string>(j, "gain_input", path);
  if (!j.contains("response")) throw ConfigError(path, 0, "response", "missing (null when there is none)");
  if (!j["response"].is_null()) {
    CameraResponse r;
    r.levels = Require<int>(j["response"], "levels", path);
    r.sensor_linear = Require<bool>(j["response"], "sensor_linear", path);
    r.inverse = Require<std::vector<std::vector<double>>>(j["response"], "inverse", path);
    p.response = r;
  }
  const auto gain = Require<std::vector<json>>(j, "gain", path);
  if (gain.size() != 3) throw ConfigError(path, 0, "gain", "needs 3 channels");
  for (int c = 0; c < 3; ++c) {
    p.gain.x[c] = Require<std::vector<double>>(gain[c], "x", path);
    p.gain.y[c] = Require<std::vector<double>>(gain[c], "y", path);
  }
  const auto ccm = Require<std::vector<std::vector<double>>>(j, "ccm", path);
  if (ccm.size() != 3) throw ConfigError(path, 0, "ccm", "needs 3 rows of 3");
  for (int r = 0; r < 3; ++r) {
    if (ccm[r].size() != 3) throw ConfigError(path, 0, "ccm", "needs 3 rows of 3");
    for (int c = 0; c < 3; ++c) p.ccm(r, c) = ccm[r][c];
  }
  if (j.contains("fit") && j["fit"].is_object()) {
    const json& f = j["fit"];
    p.fit.usable = f.value("usable", false);
    p.fit.low_confidence = f.value("low_confidence", false);
    p.fit.patches_used = f.value("patches_used", 0);
    p.fit.condition = f.value("condition", 0.0);
    p.fit.mean_delta_e = f.value("mean_delta_e_2000", 0.0);
    p.fit.max_delta_e = f.value("max_delta_e_2000", 0.0);
    p.fit.reason = f.value("reason", std::string());
    // Profiles written before 2026-12-02 have no per-patch values.
    if (f.contains("patch_delta_e_2000") && f["patch_delta_e_2000"].is_array()) {
      for (const json& de : f["patch_delta_e_2000"]) {
        p.fit.patch_delta_e.push_back(de.is_number() ? de.get<double>() : std::numeric_limits<double>::quiet_NaN());
      }
    }
  }
  std::string why;
  if (!p.IsValid(&why)) throw ConfigError(path, 0, "", why);
  return p;
}

RadianceImage ApplyProfile(const CalibrationProfile& profile, const CameraImage& frame, double exposure_time_s) {
  std::string why;
  if (!profile.IsValid(&why)) throw InvalidArgumentError("calibration profile: " + why);
  if (!frame.IsValid(&why)) throw InvalidArgumentError("frame: " + why);
  if (frame.layout != ColorLayout::kRgb) throw InvalidArgumentError("frame must be RGB (demosaic raw frames first)");
  if (!std::isfinite(exposure_time_s) || exposure_time_s <= 0.0) {
    throw InvalidArgumentError("exposure time must be a positive number of seconds");
  }
  const int levels = frame.pixels.depth() == CV_8U ? 256 : 65536;
  if (profile.response && profile.response->levels != levels) {
    throw InvalidArgumentError("the profile's response has " + std::to_string(profile.response->levels) +
                               " levels, the frame " + std::to_string(levels));
  }
  // Per-channel table: code -> value fed to the gain.
  std::array<std::vector<float>, 3> table;
  for (int c = 0; c < 3; ++c) {
    table[c].resize(levels);
    for (int z = 0; z < levels; ++z) {
      double v;
      if (profile.gain_input == "normalized_code") {
        v = std::max(0.0, static_cast<double>(z - frame.black_level) / (frame.white_level - frame.black_level));
      } else if (profile.response) {
        v = profile.response->inverse[c][z] / exposure_time_s;
      } else {
        v = std::max(0.0, static_cast<double>(z - frame.black_level) / (frame.white_level - frame.black_level)) /
            exposure_time_s;
      }
      table[c][z] = static_cast<float>(v);
    }
  }
  RadianceImage out = MakeRadianceImage(frame.width(), frame.height());
  for (int y = 0; y < frame.height(); ++y) {
    auto* o = out.pixels.ptr<cv::Vec3f>(y);
    for (int x = 0; x < frame.width(); ++x) {
      for (int c = 0; c < 3; ++c) {
        const int z = levels == 256 ? frame.pixels.ptr<std::uint8_t>(y)[3 * x + c]
                                    : frame.pixels.ptr<std::uint16_t>(y)[3 * x + c];
        o[x][c] = table[c][z];
      }
    }
  }
  CorrectPixels(profile, out.pixels);
  return out;
}

RadianceImage ApplyProfile(const CalibrationProfile& profile, const RadianceImage& radiance) {
  std::string why;
  if (!profile.IsValid(&why)) throw InvalidArgumentError("calibration profile: " + why);
  if (!radiance.IsValid(&why) || radiance.pixels.type() != CV_32FC3) {
    throw InvalidArgumentError("radiance image must be RGB float");
  }
  RadianceImage out = radiance;
  out.pixels = radiance.pixels.clone();
  CorrectPixels(profile, out.pixels);
  return out;
}

}  // namespace relume::calibration
