#include "apps/relume/session_command.h"

#include <CLI/CLI.hpp>
#include <iostream>
#include <memory>

#include "capture/import.h"
#include "capture/import_rgbd.h"
#include "capture/scene_model_record.h"
#include "capture/session.h"
#include "capture/session_check.h"
#include "core/error.h"
#include "core/scene_model_file.h"
#include "core/time.h"
#include "core/yaml_file.h"
#include "rig/scene_model_from_rig.h"

namespace relume::app {

void AddSessionCommand(CLI::App& app) {
  CLI::App* session = app.add_subcommand("session", "Check, repair and describe a capture session folder");
  session->require_subcommand(1);
  auto dir = std::make_shared<std::string>();

  CLI::App* verify = session->add_subcommand("verify", "Check every frame's file and SHA-256 against its row");
  verify->add_option("DIR", *dir, "Session folder")->required();
  verify->callback([dir]() {
    const capture::VerifyReport report = capture::VerifySession(*dir);
    std::cout << report.Summary() << "\n";
    if (!report.ok()) throw CLI::RuntimeError(1);
  });

  CLI::App* recover = session->add_subcommand(
      "recover", "Make a session that stopped mid-write consistent (keeps every acknowledged frame)");
  recover->add_option("DIR", *dir, "Session folder")->required();
  recover->callback([dir]() { std::cout << capture::RecoverSession(*dir).Summary() << "\n"; });

  CLI::App* info = session->add_subcommand("info", "Summarise a session");
  info->add_option("DIR", *dir, "Session folder")->required();
  info->callback([dir]() { std::cout << capture::DescribeSession(*dir); });

  CLI::App* import = session->add_subcommand(
      "import",
      "Make a session from still images recorded elsewhere (raw, JPEG, TIFF, PNG): files kept byte for byte with "
      "SHA-256, time and exposure from their EXIF, brackets grouped, the sun per frame; or, with --rgbd, from an "
      "RGB-D recording in the TUM RGB-D layout (rgb.txt, depth.txt)");
  auto import_options = std::make_shared<capture::ImportOptions>();
  auto inputs = std::make_shared<std::vector<std::string>>();
  auto out = std::make_shared<std::string>();
  auto site_file = std::make_shared<std::string>();
  auto tz = std::make_shared<std::string>();
  auto rgbd_options = std::make_shared<capture::RgbdImportOptions>();
  auto rgbd = std::make_shared<std::string>();
  auto intrinsics = std::make_shared<std::vector<double>>();
  import->add_option("INPUTS", *inputs, "Image files or folders of them");
  import->add_option("--out", *out, "The new session's folder")->required();
  import->add_option("--site", *site_file, "Site file (config/sites/*.yaml): where the photographs were taken")
      ->required();
  import->add_option("--tz", *tz,
                     "UTC offset of the camera's clock (+03:00) for files whose EXIF gives none (no default)");
  import->add_option("--name", import_options->name, "Session name (default: the folder's)");
  import->add_option("--camera-id", import_options->camera_id, "Device id (default: from EXIF make and model)");
  import->add_option("--bracket-gap", import_options->bracket_gap_s,
                     "Frames closer than this (s), with different exposures, form one bracket (3)");
  import->add_option("--exposure-time", import_options->exposure_time_s, "Exposure time (s) for files lacking it");
  import->add_option("--aperture", import_options->aperture_f, "f-number for files lacking it");
  import->add_option("--iso", import_options->iso, "ISO for files lacking it");
  import->add_flag(
      "--linear", import_options->linear,
      "The JPEG/TIFF/PNG files hold linear values (16-bit TIFFs from a raw converter such as dcraw -4 -T): "
      "no camera response is needed");
  import->add_option("--rgbd", *rgbd,
                     "An RGB-D recording's folder instead of INPUTS: rgb.txt and depth.txt list 'TIMESTAMP FILE' "
                     "(Unix seconds, UTC); 8/16-bit colour PNG/JPEG, 16-bit depth PNG registered to colour "
                     "(capture/import_rgbd.h)");
  import->add_option("--intrinsics", *intrinsics, "With --rgbd: the colour camera's fx,fy,cx,cy in pixels")
      ->delimiter(',')
      ->expected(4);
  import
      ->add_option("--depth-scale", rgbd_options->depth_units_per_metre,
                   "With --rgbd: depth values per metre (1000: millimetres; the TUM benchmark's files: 5000)")
      ->capture_default_str();
  import
      ->add_option("--max-pair-gap", rgbd_options->max_pair_gap_s,
                   "With --rgbd: the largest time gap (s) of a depth and a colour frame paired")
      ->capture_default_str();
  import->callback([import_options, rgbd_options, rgbd, intrinsics, inputs, out, site_file, tz]() {
    if (!rgbd->empty()) {
      if (!inputs->empty()) throw InvalidArgumentError("give either image files (INPUTS) or --rgbd DIR, not both");
  if (intrinsics->size() != 4)
    throw InvalidArgumentError("--rgbd needs --intrinsics fx,fy,cx,cy (the colour camera, pixels)");
  capture::RgbdImportOptions options = *rgbd_options;
  options.folder = *rgbd;
  options.site = LoadSiteConfig(*site_file).site;
  options.name = import_options->name;
  if (!import_options->camera_id.empty()) options.camera_id = import_options->camera_id;
  options.exposure_time_s = import_options->exposure_time_s;
  options.iso = import_options->iso;
  options.color_intrinsics.fx = (*intrinsics)[0];
  options.color_intrinsics.fy = (*intrinsics)[1];
  options.color_intrinsics.cx = (*intrinsics)[2];
  options.color_intrinsics.cy = (*intrinsics)[3];
  std::cout << capture::ImportRgbd(options, *out).Report();
  return;
}
if (inputs->empty()) throw InvalidArgumentError("session import: give image files or folders, or --rgbd DIR");
capture::ImportOptions options = *import_options;
for (const std::string& input : *inputs) options.inputs.emplace_back(input);
options.site = LoadSiteConfig(*site_file).site;
if (!tz->empty()) {
  try {
    options.utc_offset = ParseIso8601("2000-01-01T00:00:00" + *tz).utc_offset;
  } catch (const InvalidArgumentError&) {
    throw InvalidArgumentError("--tz " + *tz + ": expected an offset from UTC such as +03:00, -05:00 or Z");
  }
}
std::cout << capture::ImportStills(options, *out).Report();
}  // namespace relume::app
);

CLI::App* add_model = session->add_subcommand(
    "add-scene-model",
    "Store the scene model processing reads (cameras, geometry, lamps): from a file you wrote (--from, "
    "docs/real-data.md), or for a simulated session captured before scene models existed, from the rig and "
    "world it keeps in <session>/rig/");
add_model->add_option("DIR", *dir, "Session folder")->required();
auto from = std::make_shared<std::string>();
add_model->add_option("--from", *from, "Scene model YAML (core/scene_model_file.h, docs/real-data.md)");
add_model->callback([dir, from]() {
  std::int64_t row = 0;
  if (from->empty()) {
    row = rig::AddSceneModelFromStoredRig(*dir);
  } else {
    const SceneModel model = LoadSceneModelFile(*from, capture::SessionReader(*dir).info().site);
    row = capture::StoreSceneModel(*dir, model);
    std::cout << capture::DescribeSceneModel(model) << "\n";
  }
  std::cout << "scene model stored as calibration row " << row << " of " << *dir << "\n";
});
}  // namespace relume::app

}  // namespace relume::app
