// A simulated DSLR as a libgphoto2 camera driver ("camlib"), built on libgphoto2's public
// camera-driver API (gphoto2/gphoto2-library.h). libgphoto2 loads it like any other camlib
// when the CAMLIBS environment variable names the folder holding simcam.so, so relume's gphoto2
// backend can be tested through the real library without hardware.
//
// Conventions:
//  - Port: the "disk" port type (libgphoto2_port's disk.so), path "disk:<folder>". The folder
//    is the simulated camera's "memory card" and holds the fault control file; nothing is read
//    from any device. libgphoto2 does not autodetect disk ports that are not mounted
//    filesystems, so the camera is opened by model + port.
//  - Configuration tree like a PTP DSLR's: capturesettings/{shutterspeed, aperture,
//    exposurecompensation, imageformat}, imgsettings/iso, settings/capturetarget,
//    status/{cameramodel, serialnumber}. Like real camlibs, set_config takes any value it can
//    parse, even one that is not among the widget's choices (a real camera may then do
//    something else); validating is the caller's job.
//  - Capture renders simcam_scene.h at the current settings and stores the file in the camera
//    filesystem under /DCIM/100SIMCM/ (and also into <folder>/DCIM/100SIMCM/ when the capture
//    target is "Memory card").
//  - Faults: each operation reads <folder>/simcam-faults, lines "<op> <fault> [count]":
//      op    = init | config | capture | download | any
//      fault = busy (GP_ERROR_CAMERA_BUSY, "PTP Device Busy"), io (GP_ERROR_IO_READ),
//              disconnect (GP_ERROR_IO_USB_FIND, what the usb port returns for a vanished
//              device), claimed (GP_ERROR_IO_USB_CLAIM, what it returns when another process
//              such as gvfs holds the device)
//      count = how many operations fail (the file is rewritten with the rest); no count = all.
#include <gphoto2/gphoto2-library.h>
#include <gphoto2/gphoto2-port-result.h>
#include <gphoto2/gphoto2-result.h>
#include <gphoto2/gphoto2-widget.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "core/testing/dng_writer.h"
#include "drivers/gphoto2/simcam/simcam_scene.h"

struct _CameraPrivateLibrary {
  std::string folder;  // the disk port's folder
  std::string shutterspeed = "1/60";
  std::string aperture = "f/8";
  std::string iso = "100";
  std::string exposurecompensation = "0";
  std::string imageformat = "TIFF 16-bit";
  std::string capturetarget = "Internal RAM";
  int next_number = 1;
  struct StoredFile {
    std::vector<std::uint8_t> bytes;
    std::string mime;
    std::time_t mtime = 0;
  };
  std::map<std::string, StoredFile> files;  // by file name, all in kFolder
};

namespace {

constexpr const char* kModel = "Relume Simulated DSLR";
constexpr const char* kSerial = "SIM0001";
constexpr const char* kFolder = "/DCIM/100SIMCM";
constexpr int kWidth = 240;
constexpr int kHeight = 160;

std::vector<std::string> ShutterChoices() {
  // 1/4000 .. 30 s in third stops, as cameras label them.
  return {"1/4000", "1/3200", "1/2500", "1/2000", "1/1600", "1/1250", "1/1000", "1/800", "1/640", "1/500", "1/400",
          "1/320",  "1/250",  "1/200",  "1/160",  "1/125",  "1/100",  "1/80",   "1/60",  "1/50",  "1/40",  "1/30",
          "1/25",   "1/20",   "1/15",   "1/13",   "1/10",   "1/8",    "1/6",    "1/5",   "1/4",   "0.3",   "0.4",
          "0.5",    "0.6",    "0.8",    "1",      "1.3",    "1.6",    "2",      "2.5",   "3.2",   "4",     "5",
          "6",      "8",      "10",     "13",     "15",     "20",     "25",     "30",    "bulb"};
}
std::vector<std::string> ApertureChoices() {
  return {"f/2.8", "f/3.2", "f/3.5", "f/4",  "f/4.5", "f/5",  "f/5.6", "f/6.3", "f/7.1", "f/8",
          "f/9",   "f/10",  "f/11",  "f/13", "f/14",  "f/16", "f/18",  "f/20",  "f/22"};
}
std::vector<std::string> IsoChoices() {
  return {"Auto", "100", "200", "400", "800", "1600", "3200", "6400"};
}
std::vector<std::string> EvChoices() {
  std::vector<std::string> out;
  for (int i = -9; i <= 9; ++i) {
    char text[16];
    std::snprintf(text, sizeof(text), "%g", std::round(i / 3.0 * 10.0) / 10.0);
    out.emplace_back(text);
  }
  return out;
}
std::vector<std::string> FormatChoices() {
  return {"JPEG", "TIFF 16-bit", "RAW"};
}
std::vector<std::string> TargetChoices() {
  return {"Internal RAM", "Memory card"};
}

// Parses "1/250", "0.3", "30", "f/5.6", "5.6"; false when it is not a number.
bool ParseNumber(std::string text, double* value) {
  if (text.rfind("f/", 0) == 0) text = text.substr(2);
  const std::size_t slash = text.find('/');
  char* end = nullptr;
  if (slash != std::string::npos) {
    const std::string num_text = text.substr(0, slash);
    const double num = std::strtod(num_text.c_str(), &end);
    if (*end != '\0' || num_text.empty()) return false;
    const std::string den_text = text.substr(slash + 1);
    const double den = std::strtod(den_text.c_str(), &end);
    if (*end != '\0' || den_text.empty() || den <= 0.0) return false;
    *value = num / den;
    return true;
  }
  if (text.empty()) return false;
  *value = std::strtod(text.c_str(), &end);
  return *end == '\0';
}

// ---- faults -------------------------------------------------------------------------------

int FaultCode(const std::string& fault) {
  if (fault == "busy") return GP_ERROR_CAMERA_BUSY;
  if (fault == "io") return GP_ERROR_IO_READ;
  if (fault == "disconnect") return GP_ERROR_IO_USB_FIND;
  if (fault == "claimed") return GP_ERROR_IO_USB_CLAIM;
  return GP_OK;
}

const char* FaultMessage(int code) {
  switch (code) {
    case GP_ERROR_CAMERA_BUSY: return "PTP Device Busy";
    case GP_ERROR_IO_READ: return "simulated USB read failure";
    case GP_ERROR_IO_USB_FIND: return "the simulated camera is gone (cable unplugged)";
    case GP_ERROR_IO_USB_CLAIM: return "Could not claim the USB device (held by another process)";
    default: return "simulated fault";
  }
}

// Consumes one fault for `op` from the control file in `folder`; GP_OK when none applies.
int TakeFault(const std::string& folder, const std::string& op, GPContext* context) {
  const std::filesystem::path path = std::filesystem::path(folder) / "simcam-faults";
  std::ifstream in(path);
  if (!in) return GP_OK;
  std::vector<std::string> lines;
  std::string line;
  int code = GP_OK;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string line_op, fault;
    long count = -1;
    fields >> line_op >> fault;
    if (!(fields >> count)) count = -1;
    if (code == GP_OK && (line_op == op || line_op == "any") && FaultCode(fault) != GP_OK && count != 0) {
      code = FaultCode(fault);
      if (count > 0) --count;
      if (count == 0) continue;  // used up: drop the line
      std::ostringstream kept;
      kept << line_op << ' ' << fault;
      if (count > 0) kept << ' ' << count;
      lines.push_back(kept.str());
      continue;
    }
    lines.push_back(line);
  }
  in.close();
  std::ofstream out(path, std::ios::trunc);
  for (const std::string& kept : lines) out << kept << "\n";
  if (code != GP_OK) gp_context_error(context, "%s", FaultMessage(code));
  return code;
}

// ---- configuration --------------------------------------------------------------------------

int AddRadio(CameraWidget* section, const char* name, const char* label, const std::vector<std::string>& choices,
             const std::string& value) {
  CameraWidget* widget = nullptr;
  int result = gp_widget_new(GP_WIDGET_RADIO, label, &widget);
  if (result < GP_OK) return result;
  gp_widget_set_name(widget, name);
  for (const std::string& choice : choices) gp_widget_add_choice(widget, choice.c_str());
  gp_widget_set_value(widget, value.c_str());
  return gp_widget_append(section, widget);
}

int AddText(CameraWidget* section, const char* name, const char* label, const char* value) {
  CameraWidget* widget = nullptr;
  int result = gp_widget_new(GP_WIDGET_TEXT, label, &widget);
  if (result < GP_OK) return result;
  gp_widget_set_name(widget, name);
  gp_widget_set_value(widget, value);
  gp_widget_set_readonly(widget, 1);
  return gp_widget_append(section, widget);
}

CameraWidget* AddSection(CameraWidget* root, const char* name, const char* label) {
  CameraWidget* section = nullptr;
  gp_widget_new(GP_WIDGET_SECTION, label, &section);
  gp_widget_set_name(section, name);
  gp_widget_append(root, section);
  return section;
}

int SimGetConfig(Camera* camera, CameraWidget** window, GPContext* context) {
  CameraPrivateLibrary* pl = camera->pl;
  if (int fault = TakeFault(pl->folder, "config", context); fault != GP_OK) return fault;
  gp_widget_new(GP_WIDGET_WINDOW, "Camera and Driver Configuration", window);
  gp_widget_set_name(*window, "main");
  CameraWidget* capture = AddSection(*window, "capturesettings", "Capture Settings");
  AddRadio(capture, "shutterspeed", "Shutter Speed", ShutterChoices(), pl->shutterspeed);
  AddRadio(capture, "aperture", "Aperture", ApertureChoices(), pl->aperture);
  AddRadio(capture, "exposurecompensation", "Exposure Compensation", EvChoices(), pl->exposurecompensation);
  AddRadio(capture, "imageformat", "Image Format", FormatChoices(), pl->imageformat);
  CameraWidget* image = AddSection(*window, "imgsettings", "Image Settings");
  AddRadio(image, "iso", "ISO Speed", IsoChoices(), pl->iso);
  CameraWidget* settings = AddSection(*window, "settings", "Camera Settings");
  AddRadio(settings, "capturetarget", "Capture Target", TargetChoices(), pl->capturetarget);
  CameraWidget* status = AddSection(*window, "status", "Camera Status Information");
  AddText(status, "cameramodel", "Camera Model", kModel);
  AddText(status, "serialnumber", "Serial Number", kSerial);
  return GP_OK;
}

// Copies a changed widget's value into `field` when it parses (numeric fields) or is non-empty.
int TakeValue(CameraWidget* window, const char* name, bool numeric, std::string* field, GPContext* context) {
  CameraWidget* widget = nullptr;
  if (gp_widget_get_child_by_name(window, name, &widget) < GP_OK) return GP_OK;
  if (!gp_widget_changed(widget)) return GP_OK;
  gp_widget_set_changed(widget, 0);
  const char* value = nullptr;
  if (gp_widget_get_value(widget, &value) < GP_OK || value == nullptr) return GP_ERROR_BAD_PARAMETERS;
  double number = 0.0;
  if (numeric && std::strcmp(value, "Auto") != 0 && std::strcmp(value, "bulb") != 0 && !ParseNumber(value, &number)) {
    gp_context_error(context, "cannot parse '%s' for %s", value, name);
    return GP_ERROR_BAD_PARAMETERS;
  }
  *field = value;
  return GP_OK;
}

int SimSetConfig(Camera* camera, CameraWidget* window, GPContext* context) {
  CameraPrivateLibrary* pl = camera->pl;
  if (int fault = TakeFault(pl->folder, "config", context); fault != GP_OK) return fault;
  int result = GP_OK;
  if (result == GP_OK) result = TakeValue(window, "shutterspeed", true, &pl->shutterspeed, context);
  if (result == GP_OK) result = TakeValue(window, "aperture", true, &pl->aperture, context);
  if (result == GP_OK) result = TakeValue(window, "iso", true, &pl->iso, context);
  if (result == GP_OK) result = TakeValue(window, "exposurecompensation", true, &pl->exposurecompensation, context);
  if (result == GP_OK) result = TakeValue(window, "imageformat", false, &pl->imageformat, context);
  if (result == GP_OK) result = TakeValue(window, "capturetarget", false, &pl->capturetarget, context);
  return result;
}

// ---- capture --------------------------------------------------------------------------------

int SimCapture(Camera* camera, CameraCaptureType type, CameraFilePath* path, GPContext* context) {
  CameraPrivateLibrary* pl = camera->pl;
  if (type != GP_CAPTURE_IMAGE) return GP_ERROR_NOT_SUPPORTED;
  if (int fault = TakeFault(pl->folder, "capture", context); fault != GP_OK) return fault;
  double time_s = 0.0, aperture_f = 0.0, iso = 100.0, ev = 0.0;
  if (pl->shutterspeed == "bulb") {
    gp_context_error(context, "bulb exposures need trigger + release; not simulated");
    return GP_ERROR_NOT_SUPPORTED;
  }
  ParseNumber(pl->shutterspeed, &time_s);
  ParseNumber(pl->aperture, &aperture_f);
  if (pl->iso != "Auto") ParseNumber(pl->iso, &iso);
  ParseNumber(pl->exposurecompensation, &ev);
  if (time_s <= 0.0 || aperture_f <= 0.0 || iso <= 0.0) return GP_ERROR_BAD_PARAMETERS;
  const double scale = relume::drivers::simcam::ExposureScale(time_s, aperture_f, iso, ev);

  CameraPrivateLibrary::StoredFile file;
  const char* extension = "JPG";
  if (pl->imageformat == "RAW") {
    // The sensor's RGGB mosaic as a DNG (simcam_scene.h: RAW).
    relume::testing::DngImage raw;
    raw.mosaic = cv::Mat(kHeight, kWidth, CV_16UC1);
    raw.black_level = relume::drivers::simcam::kRawBlack;
    raw.white_level = relume::drivers::simcam::kRawWhite;
    raw.exposure_time_s = time_s;
    raw.aperture_f = aperture_f;
    raw.model = kModel;
    for (int v = 0; v < kHeight; ++v) {
      for (int u = 0; u < kWidth; ++u) {
        const int c = (v % 2 == 0) ? (u % 2 == 0 ? 0 : 1) : (u % 2 == 0 ? 1 : 2);
        raw.mosaic.ptr<std::uint16_t>(v)[u] = relume::drivers::simcam::RawCount(
            std::min(1.0, scale * relume::drivers::simcam::SceneRadiance(u, v, c, kWidth, kHeight)));
      }
    }
    file.bytes = relume::testing::EncodeDng(raw);
    file.mime = "image/x-adobe-dng";
    extension = "DNG";
  } else {
    const bool tiff = pl->imageformat == "TIFF 16-bit";
    cv::Mat bgr(kHeight, kWidth, tiff ? CV_16UC3 : CV_8UC3);
    for (int v = 0; v < kHeight; ++v) {
      for (int u = 0; u < kWidth; ++u) {
        for (int c = 0; c < 3; ++c) {
          const double s = std::min(1.0, scale * relume::drivers::simcam::SceneRadiance(u, v, c, kWidth, kHeight));
          const int bgr_channel = 2 - c;
          if (tiff) {
            bgr.ptr<std::uint16_t>(v)[3 * u + bgr_channel] = static_cast<std::uint16_t>(std::lround(65535.0 * s));
          } else {
            bgr.ptr<std::uint8_t>(v)[3 * u + bgr_channel] =
                static_cast<std::uint8_t>(std::lround(255.0 * std::pow(s, 1.0 / 2.2)));
          }
        }
      }
    }
    std::vector<int> params;
    if (!tiff) params = {cv::IMWRITE_JPEG_QUALITY, 95};
    if (!cv::imencode(tiff ? ".tif" : ".jpg", bgr, file.bytes, params)) return GP_ERROR_CORRUPTED_DATA;
    file.mime = tiff ? GP_MIME_TIFF : GP_MIME_JPEG;
    if (tiff) extension = "TIF";
  }
  file.mtime = std::time(nullptr);
  char name[32];
  std::snprintf(name, sizeof(name), "SIM_%04d.%s", pl->next_number++ % 10000, extension);
  if (pl->capturetarget == "Memory card") {
    const std::filesystem::path card = std::filesystem::path(pl->folder) / "DCIM" / "100SIMCM";
    std::error_code error;
    std::filesystem::create_directories(card, error);
    std::ofstream out(card / name, std::ios::binary);
    out.write(reinterpret_cast<const char*>(file.bytes.data()), static_cast<std::streamsize>(file.bytes.size()));
    if (!out) return GP_ERROR_NO_SPACE;
  }
  pl->files[name] = std::move(file);
  std::snprintf(path->folder, sizeof(path->folder), "%s", kFolder);
  std::snprintf(path->name, sizeof(path->name), "%s", name);
  return gp_filesystem_append(camera->fs, kFolder, name, context);
}

// ---- filesystem -----------------------------------------------------------------------------

int SimFolderList(CameraFilesystem*, const char* folder, CameraList* list, void*, GPContext*) {
  if (std::strcmp(folder, "/") == 0) return gp_list_append(list, "DCIM", nullptr);
  if (std::strcmp(folder, "/DCIM") == 0) return gp_list_append(list, "100SIMCM", nullptr);
  return GP_OK;
}

int SimFileList(CameraFilesystem*, const char* folder, CameraList* list, void* data, GPContext*) {
  auto* camera = static_cast<Camera*>(data);
  if (std::strcmp(folder, kFolder) != 0) return GP_OK;
  for (const auto& [name, file] : camera->pl->files) gp_list_append(list, name.c_str(), nullptr);
  return GP_OK;
}

int SimGetInfo(CameraFilesystem*, const char* folder, const char* filename, CameraFileInfo* info, void* data,
               GPContext*) {
  auto* camera = static_cast<Camera*>(data);
  const auto found = camera->pl->files.find(filename);
  if (std::strcmp(folder, kFolder) != 0 || found == camera->pl->files.end()) return GP_ERROR_FILE_NOT_FOUND;
  std::memset(info, 0, sizeof(*info));
  info->file.fields = static_cast<CameraFileInfoFields>(GP_FILE_INFO_TYPE | GP_FILE_INFO_SIZE | GP_FILE_INFO_MTIME |
                                                        GP_FILE_INFO_WIDTH | GP_FILE_INFO_HEIGHT);
  std::snprintf(info->file.type, sizeof(info->file.type), "%s", found->second.mime.c_str());
  info->file.size = found->second.bytes.size();
  info->file.mtime = found->second.mtime;
  info->file.width = kWidth;
  info->file.height = kHeight;
  return GP_OK;
}

int SimGetFile(CameraFilesystem*, const char* folder, const char* filename, CameraFileType type, CameraFile* file,
               void* data, GPContext* context) {
  auto* camera = static_cast<Camera*>(data);
  if (int fault = TakeFault(camera->pl->folder, "download", context); fault != GP_OK) return fault;
  const auto found = camera->pl->files.find(filename);
  if (std::strcmp(folder, kFolder) != 0 || found == camera->pl->files.end()) return GP_ERROR_FILE_NOT_FOUND;
  if (type != GP_FILE_TYPE_NORMAL) return GP_ERROR_NOT_SUPPORTED;
  const std::vector<std::uint8_t>& bytes = found->second.bytes;
  int result = gp_file_append(file, reinterpret_cast<const char*>(bytes.data()), bytes.size());
  if (result < GP_OK) return result;
  gp_file_set_mime_type(file, found->second.mime.c_str());
  gp_file_set_mtime(file, found->second.mtime);
  return GP_OK;
}

int SimDeleteFile(CameraFilesystem*, const char* folder, const char* filename, void* data, GPContext*) {
  auto* camera = static_cast<Camera*>(data);
  if (std::strcmp(folder, kFolder) != 0 || camera->pl->files.erase(filename) == 0) return GP_ERROR_FILE_NOT_FOUND;
  return GP_OK;
}

int SimExit(Camera* camera, GPContext*) {
  delete camera->pl;
  camera->pl = nullptr;
  return GP_OK;
}

int SimSummary(Camera*, CameraText* text, GPContext*) {
  std::snprintf(text->text, sizeof(text->text), "%s, serial %s: relume's simulated camera driver.", kModel, kSerial);
  return GP_OK;
}

CameraFilesystemFuncs g_filesystem_funcs = [] {
  CameraFilesystemFuncs funcs;
  std::memset(&funcs, 0, sizeof(funcs));
  funcs.file_list_func = SimFileList;
  funcs.folder_list_func = SimFolderList;
  funcs.get_info_func = SimGetInfo;
  funcs.get_file_func = SimGetFile;
  funcs.del_file_func = SimDeleteFile;
  return funcs;
}();

}  // namespace

extern "C" {

int camera_id(CameraText* id) {
  std::snprintf(id->text, sizeof(id->text), "relume-simcam");
  return GP_OK;
}

int camera_abilities(CameraAbilitiesList* list) {
  CameraAbilities abilities;
  std::memset(&abilities, 0, sizeof(abilities));
  std::snprintf(abilities.model, sizeof(abilities.model), "%s", kModel);
  abilities.status = GP_DRIVER_STATUS_TESTING;
  abilities.port = GP_PORT_DISK;
  abilities.operations = static_cast<CameraOperation>(GP_OPERATION_CAPTURE_IMAGE | GP_OPERATION_CONFIG);
  abilities.file_operations = GP_FILE_OPERATION_DELETE;
  abilities.folder_operations = GP_FOLDER_OPERATION_NONE;
  abilities.device_type = GP_DEVICE_STILL_CAMERA;
  return gp_abilities_list_append(list, abilities);
}

int camera_init(Camera* camera, GPContext* context) {
  GPPortInfo info;
  int result = gp_port_get_info(camera->port, &info);
  if (result < GP_OK) return result;
  char* path = nullptr;
  result = gp_port_info_get_path(info, &path);
  if (result < GP_OK) return result;
  std::string folder = path;
  if (folder.rfind("disk:", 0) != 0 || folder.size() <= 5) {
    gp_context_error(context, "the simulated camera needs a port 'disk:<folder>', not '%s'", path);
    return GP_ERROR_UNKNOWN_PORT;
  }
  folder = folder.substr(5);
  if (!std::filesystem::is_directory(folder)) {
    gp_context_error(context, "the simulated camera's folder '%s' does not exist", folder.c_str());
    return GP_ERROR_IO_USB_FIND;
  }
  if (int fault = TakeFault(folder, "init", context); fault != GP_OK) return fault;
  camera->pl = new CameraPrivateLibrary;
  camera->pl->folder = folder;
  camera->functions->exit = SimExit;
  camera->functions->get_config = SimGetConfig;
  camera->functions->set_config = SimSetConfig;
  camera->functions->capture = SimCapture;
  camera->functions->summary = SimSummary;
  return gp_filesystem_set_funcs(camera->fs, &g_filesystem_funcs, camera);
}

}  // extern "C"
