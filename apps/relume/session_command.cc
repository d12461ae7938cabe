#include "apps/relume/session_command.h"

#include <CLI/CLI.hpp>
#include <iostream>
#include <memory>

#include "capture/durable_file.h"
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

#if RELUME_HAVE_OPENNI2
#include "drivers/openni2/openni2_backend.h"
#endif

namespace relume::app {

namespace {

// `session import --oni`: the recording played through OpenNI2's file driver into
// capture::ImportRgbdStream.
capture::RgbdImportSummary ImportOni(const std::string& path, capture::RgbdStreamImportOptions options,
                                     const std::string& out) {
#if RELUME_HAVE_OPENNI2
  if (!std::filesystem::is_regular_file(path)) throw IoError(path, "no such .oni file");
  drivers::openni2::OpenNI2Backend backend;
  const std::unique_ptr<drivers::openni2::OpenNI2Sensor> player = backend.Open(path);
  const std::vector<drivers::RgbdStreamConfig> configs = player->SupportedConfigs();
  if (configs.empty()) throw InvalidArgumentError(path + ": the recording holds no depth + colour streams");
  player->Start(configs.front());
  options.frames = player->RecordingFrameCount();
  options.model = "OpenNI2 recording";
  options.source = path;
  options.source_sha256 = capture::Sha256HexOfRegularFile(path);
  capture::RgbdImportSummary summary = capture::ImportRgbdStream(*player, options, out);
  player->Stop();
  return summary;
#else
  (void)options;
  (void)out;
  throw InvalidArgumentError(path + ": this relume was built without OpenNI2 (install libopenni2-dev and rebuild)");
#endif
}

// `session import`'s arguments: stills (INPUTS), an RGB-D folder (--rgbd) or an .oni (--oni).
struct ImportArgs {
  capture::ImportOptions stills;
  capture::RgbdImportOptions rgbd;
  std::vector<std::string> inputs;
  std::string out, site_file, tz, rgbd_dir, oni, start;
  std::vector<double> intrinsics;
  bool registered = false;
};

void RunImport(const ImportArgs& a) {
  const int sources = !a.inputs.empty() + !a.rgbd_dir.empty() + !a.oni.empty();
  if (sources != 1)
    throw InvalidArgumentError("session import: give one of image files or folders, --rgbd DIR or --oni FILE");
  const Site site = LoadSiteConfig(a.site_file).site;
  if (!a.oni.empty()) {
    if (a.start.empty()) throw InvalidArgumentError("--oni needs --start: the UTC of the recording's first frame");
    capture::RgbdStreamImportOptions options;
    options.site = site;
    options.name = a.stills.name;
    if (!a.stills.camera_id.empty()) options.camera_id = a.stills.camera_id;
    options.start_utc = ParseIso8601(a.start).utc;
    options.registered = a.registered;
    std::cout << ImportOni(a.oni, options, a.out).Report();
    return;
  }
  if (!a.rgbd_dir.empty()) {
    if (a.intrinsics.size() != 4)
      throw InvalidArgumentError("--rgbd needs --intrinsics fx,fy,cx,cy (the colour camera, pixels)");
    capture::RgbdImportOptions options = a.rgbd;
    options.folder = a.rgbd_dir;
    options.site = site;
    options.name = a.stills.name;
    if (!a.stills.camera_id.empty()) options.camera_id = a.stills.camera_id;
    options.exposure_time_s = a.stills.exposure_time_s;
    options.iso = a.stills.iso;
    options.color_intrinsics.fx = a.intrinsics[0];
    options.color_intrinsics.fy = a.intrinsics[1];
    options.color_intrinsics.cx = a.intrinsics[2];
    options.color_intrinsics.cy = a.intrinsics[3];
    std::cout << capture::ImportRgbd(options, a.out).Report();
    return;
  }
  capture::ImportOptions options = a.stills;
  for (const std::string& input : a.inputs) options.inputs.emplace_back(input);
  options.site = site;
  if (!a.tz.empty()) {
    try {
      options.utc_offset = ParseIso8601("2000-01-01T00:00:00" + a.tz).utc_offset;
    } catch (const InvalidArgumentError&) {
      throw InvalidArgumentError("--tz " + a.tz + ": expected an offset from UTC such as +03:00, -05:00 or Z");
    }
  }
  std::cout << capture::ImportStills(options, a.out).Report();
}

struct MeshArgs {
  std::string path;
  std::string name;
  std::string kind = "solid";
  MeshPlacement placement;
  std::vector<double> offset;
};

// `session add-scene-model`: a scene file (--from) and/or a mesh (--mesh) on top of the latest
// model, or, with neither, the model of the simulated rig the session stored.
void RunAddSceneModel(const std::string& dir, const std::string& from, MeshArgs mesh) {
  std::int64_t row = 0;
  if (from.empty() && mesh.path.empty()) {
    row = rig::AddSceneModelFromStoredRig(dir);
  } else {
    const Site site = capture::SessionReader(dir).info().site;
    SceneModel model;
    if (!from.empty()) {
      model = LoadSceneModelFile(from, site);
    } else if (std::optional<SceneModel> latest = capture::LatestSceneModel(dir)) {
      model = *latest;
    } else {
      model.site = site;
      model.source = "relume session add-scene-model --mesh";
    }
    if (!mesh.path.empty()) {
      if (mesh.offset.size() != 0 && mesh.offset.size() != 3) {
        throw InvalidArgumentError("--offset takes three numbers a,b,c");
      }
      if (mesh.offset.size() == 3) mesh.placement.offset = {mesh.offset[0], mesh.offset[1], mesh.offset[2]};
      const std::string name = mesh.name.empty() ? std::filesystem::path(mesh.path).stem().string() : mesh.name;
      AddMeshObject(&model, name, SceneModelObjectKindFromString(mesh.kind), mesh.path, mesh.placement);
    }
    row = capture::StoreSceneModel(dir, model);
    std::cout << capture::DescribeSceneModel(model) << "\n";
  }
  std::cout << "scene model stored as calibration row " << row << " of " << dir << "\n";
}

void AddImportCommand(CLI::App& session) {
  CLI::App* import = session.add_subcommand(
      "import",
      "Make a session from still images recorded elsewhere (raw, JPEG, TIFF, PNG): files kept byte for byte with "
      "SHA-256, time and exposure from their EXIF, brackets grouped, the sun per frame; or from an RGB-D "
      "recording: a folder in the TUM RGB-D layout (--rgbd) or an OpenNI2 .oni file (--oni)");
  auto a = std::make_shared<ImportArgs>();
  import->add_option("INPUTS", a->inputs, "Image files or folders of them");
  import->add_option("--out", a->out, "The new session's folder")->required();
  import->add_option("--site", a->site_file, "Site file (config/sites/*.yaml): where the photographs were taken")
      ->required();
  import->add_option("--tz", a->tz,
                     "UTC offset of the camera's clock (+03:00) for files whose EXIF gives none (no default)");
  import->add_option("--name", a->stills.name, "Session name (default: the folder's)");
  import->add_option("--camera-id", a->stills.camera_id,
                     "Device id (default: stills from EXIF make and model; RGB-D: rgbd)");
  import->add_option("--bracket-gap", a->stills.bracket_gap_s,
                     "Frames closer than this (s), with different exposures, form one bracket (3)");
  import->add_option("--exposure-time", a->stills.exposure_time_s,
                     "Exposure time (s) for files lacking it (--rgbd: of every colour frame)");
  import->add_option("--aperture", a->stills.aperture_f, "f-number for files lacking it");
  import->add_option("--iso", a->stills.iso, "ISO for files lacking it (--rgbd: of every colour frame)");
  import->add_flag(
      "--linear", a->stills.linear,
      "The JPEG/TIFF/PNG files hold linear values (16-bit TIFFs from a raw converter such as dcraw -4 -T): "
      "no camera response is needed");
  import->add_option("--rgbd", a->rgbd_dir,
                     "An RGB-D recording's folder instead of INPUTS: rgb.txt and depth.txt list 'TIMESTAMP FILE' "
                     "(Unix seconds, UTC); 8/16-bit colour PNG/JPEG, 16-bit depth PNG registered to colour "
                     "(capture/import_rgbd.h)");
  import->add_option("--intrinsics", a->intrinsics, "With --rgbd: the colour camera's fx,fy,cx,cy in pixels")
      ->delimiter(',')
      ->expected(4);
  import
      ->add_option("--depth-scale", a->rgbd.depth_units_per_metre,
                   "With --rgbd: depth values per metre (1000: millimetres; the TUM benchmark's files: 5000)")
      ->capture_default_str();
  import
      ->add_option("--max-pair-gap", a->rgbd.max_pair_gap_s,
                   "With --rgbd: the largest time gap (s) of a depth and a colour frame paired")
      ->capture_default_str();
  import->add_option("--oni", a->oni,
                     "An OpenNI2 recording (.oni) instead of INPUTS, played through OpenNI2 in real time; needs "
                     "--start");
  import->add_option("--start", a->start,
                     "With --oni: UTC of the recording's first frame (2026-03-20T11:00:00Z; .oni files hold no "
                     "wall-clock time)");
  import->add_flag("--registered", a->registered,
                   "With --oni: depth was registered to colour when recorded (.oni files do not say)");
  import->callback([a]() { RunImport(*a);
});
}  // namespace

}  // namespace relume::app

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

  AddImportCommand(*session);

  CLI::App* add_model = session->add_subcommand(
      "add-scene-model",
      "Store the scene model processing reads (cameras, geometry, lamps): from a file you wrote (--from, "
      "docs/real-data.md), or for a simulated session captured before scene models existed, from the rig and "
      "world it keeps in <session>/rig/");
  add_model->add_option("DIR", *dir, "Session folder")->required();
  auto from = std::make_shared<std::string>();
  add_model->add_option("--from", *from, "Scene model YAML (core/scene_model_file.h, docs/real-data.md)");
  auto mesh = std::make_shared<MeshArgs>();
  add_model->add_option("--mesh", mesh->path,
                        "A mesh (OBJ/PLY, e.g. a photogrammetry export) added to the session's latest scene model "
                        "(or to --from's)");
  add_model->add_option("--name", mesh->name, "With --mesh: the object's name (default: the file's stem)");
  add_model->add_option("--kind", mesh->kind, "With --mesh: solid (closed) or surface")->capture_default_str();
  add_model->add_option("--mesh-frame", mesh->placement.frame, "With --mesh: enu or utm")->capture_default_str();
  add_model->add_option("--utm-zone", mesh->placement.utm_zone, "With --mesh-frame utm: the zone (0: the site's)")
      ->capture_default_str();
  add_model
      ->add_option("--offset", mesh->offset,
                   "With --mesh: a,b,c added to every vertex (the export's georeferencing shift)")
      ->delimiter(',')
      ->expected(3);
  add_model->callback([dir, from, mesh]() { RunAddSceneModel(*dir, *from, *mesh); });
}

}  // namespace relume::app
