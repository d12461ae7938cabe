#include "drivers/gphoto2/gphoto2_backend.h"

#include <gphoto2/gphoto2.h>

#include <algorithm>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "core/error.h"
#include "core/raw_file.h"
#include "drivers/gphoto2/gphoto2_values.h"

namespace relume::drivers::gphoto2 {
namespace {

// A GPContext that keeps the error messages libgphoto2 and the camera driver report, so that
// exceptions can carry them.
class Context {
 public:
  Context() : context_(gp_context_new()) {
    gp_context_set_error_func(context_, &Context::OnError, this);
    gp_context_set_message_func(context_, &Context::OnError, this);
  }
  ~Context() { gp_context_unref(context_); }
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;
  GPContext* get() { return context_; }
  std::string TakeMessages() {
    std::string out;
    out.swap(messages_);
    return out;
  }

 private:
  static void OnError(GPContext*, const char* text, void* data) {
    auto* self = static_cast<Context*>(data);
    if (!self->messages_.empty()) self->messages_ += "; ";
    self->messages_ += text;
    // Status messages arrive without errors too: keep only the recent ones.
    constexpr std::size_t kKeep = 2000;
    if (self->messages_.size() > 2 * kKeep) self->messages_.erase(0, self->messages_.size() - kKeep);
  }
  GPContext* context_;
  std::string messages_;
};

// Throws the DeviceError for a failed libgphoto2 call.
[[noreturn]] void ThrowGphoto(int result, const std::string& device_id, const std::string& doing, Context& context,
                              bool opening = false) {
  const DeviceErrorKind kind = KindFromGphotoResult(result, opening);
  std::ostringstream what;
  what << doing << " failed: " << gp_result_as_string(result) << " (libgphoto2 " << result << ")";
  const std::string messages = context.TakeMessages();
  if (!messages.empty()) what << ": " << messages;
  if (kind == DeviceErrorKind::kAccessDenied) what << "; " << ClaimedByAnotherProcessHint();
  if (kind == DeviceErrorKind::kBusy) what << " (the camera is busy; retry after a pause)";
  throw DeviceError(kind, device_id, what.str());
}

std::vector<std::string> WidgetChoices(CameraWidget* widget) {
  std::vector<std::string> out;
  const int count = gp_widget_count_choices(widget);
  for (int i = 0; i < count; ++i) {
    const char* choice = nullptr;
    if (gp_widget_get_choice(widget, i, &choice) == GP_OK && choice != nullptr) out.emplace_back(choice);
  }
  return out;
}

// The value of a leaf widget as text (numbers and toggles formatted), "" for sections.
std::string WidgetValue(CameraWidget* widget) {
  CameraWidgetType type;
  gp_widget_get_type(widget, &type);
  switch (type) {
    case GP_WIDGET_TEXT:
    case GP_WIDGET_RADIO:
    case GP_WIDGET_MENU: {
      const char* value = nullptr;
      gp_widget_get_value(widget, &value);
      return value != nullptr ? value : "";
    }
    case GP_WIDGET_RANGE: {
      float value = 0.0f;
      gp_widget_get_value(widget, &value);
      std::ostringstream text;
      text << value;
      return text.str();
    }
    case GP_WIDGET_TOGGLE:
    case GP_WIDGET_DATE: {
      int value = 0;
      gp_widget_get_value(widget, &value);
      return std::to_string(value);
    }
    default: return "";
  }
}

void CollectLeafNames(CameraWidget* widget, std::vector<std::string>* names) {
  const int children = gp_widget_count_children(widget);
  if (children <= 0) {
    CameraWidgetType type;
    gp_widget_get_type(widget, &type);
    if (type != GP_WIDGET_WINDOW && type != GP_WIDGET_SECTION) {
      const char* name = nullptr;
      gp_widget_get_name(widget, &name);
      if (name != nullptr) names->emplace_back(name);
    }
    return;
  }
  for (int i = 0; i < children; ++i) {
    CameraWidget* child = nullptr;
    if (gp_widget_get_child(widget, i, &child) == GP_OK) CollectLeafNames(child, names);
  }
}

}  // namespace

// ---- library state --------------------------------------------------------------------------

struct GPhoto2Backend::Library {
  CameraAbilitiesList* abilities = nullptr;
  GPPortInfoList* ports = nullptr;
  Context context;

  Library() {
    gp_abilities_list_new(&abilities);
    gp_port_info_list_new(&ports);
    int result = gp_abilities_list_load(abilities, context.get());
    if (result < GP_OK) ThrowGphoto(result, "gphoto2", "loading the camera drivers (camlibs)", context);
    result = gp_port_info_list_load(ports);
    if (result < GP_OK) ThrowGphoto(result, "gphoto2", "loading the port drivers (iolibs)", context);
  }
  ~Library() {
    gp_port_info_list_free(ports);
    gp_abilities_list_free(abilities);
  }
  Library(const Library&) = delete;
  Library& operator=(const Library&) = delete;
};

bool GPhoto2BackendOptions::IsValid(std::string* why) const {
  for (const GPhoto2CameraAddress& address : configured) {
    if (address.model.empty() || address.port.empty()) {
      if (why) *why = "every configured camera needs a model and a port (e.g. \"ptpip:192.168.1.1\")";
      return false;
    }
    if (address.port.find(':') == std::string::npos) {
      if (why) *why = "port '" + address.port + "' has no type prefix (usb:, ptpip:, disk:, serial:)";
      return false;
    }
  }
  return true;
}

GPhoto2Backend::GPhoto2Backend(GPhoto2BackendOptions options) : options_(std::move(options)) {
  ThrowIfInvalid(options_, "gphoto2 backend options");
}
GPhoto2Backend::~GPhoto2Backend() = default;

namespace {
DeviceInfo MakeInfo(const GPhoto2CameraAddress& address) {
  DeviceInfo info;
  info.backend = "gphoto2";
  info.id = address.model + "@" + address.port;
  info.kind = DeviceKind::kStillCamera;
  info.model = address.model;
  info.address = address.port;
  return info;
}

GPhoto2CameraAddress AddressFromId(const DeviceInfo& info) {
  if (!info.model.empty() && !info.address.empty()) return {info.model, info.address};
  const std::size_t at = info.id.rfind('@');
  if (at == std::string::npos) {
    throw InvalidArgumentError("gphoto2 device id '" + info.id + "' is not of the form <model>@<port>");
  }
  return {info.id.substr(0, at), info.id.substr(at + 1)};
}
}  // namespace

std::vector<DeviceInfo> GPhoto2Backend::Enumerate() {
  library_ = std::make_shared<Library>();  // reload: drivers and ports may have changed
  std::vector<DeviceInfo> out;
  if (options_.autodetect) {
    CameraList* list = nullptr;
    gp_list_new(&list);
    const int result = gp_camera_autodetect(list, library_->context.get());
    if (result < GP_OK) {
      gp_list_free(list);
      ThrowGphoto(result, "gphoto2", "autodetecting cameras", library_->context);
    }
    for (int i = 0; i < gp_list_count(list); ++i) {
      const char* model = nullptr;
      const char* port = nullptr;
      gp_list_get_name(list, i, &model);
      gp_list_get_value(list, i, &port);
      DeviceInfo info = MakeInfo({model ? model : "", port ? port : ""});
      info.details["source"] = "autodetected";
      out.push_back(std::move(info));
    }
    gp_list_free(list);
  }
  for (const GPhoto2CameraAddress& address : options_.configured) {
    // A configured camera is listed only when it answers: open it once.
    try {
      const std::unique_ptr<GPhoto2Camera> camera = Open(address);
      DeviceInfo info = camera->info();
      info.details["source"] = "configured";
      out.push_back(std::move(info));
    } catch (const DeviceError&) {
      // Absent or unusable right now: not listed (opening it says why).
    }
  }
  return out;
}

std::vector<std::string> GPhoto2Backend::SupportedModels() {
  if (!library_) library_ = std::make_shared<Library>();
  std::vector<std::string> out;
  const int count = gp_abilities_list_count(library_->abilities);
  for (int i = 0; i < count; ++i) {
    CameraAbilities abilities;
    if (gp_abilities_list_get_abilities(library_->abilities, i, &abilities) == GP_OK) out.emplace_back(abilities.model);
  }
  return out;
}

std::unique_ptr<GPhoto2Camera> GPhoto2Backend::Open(const GPhoto2CameraAddress& address) {
  if (!library_) library_ = std::make_shared<Library>();
  return std::unique_ptr<GPhoto2Camera>(new GPhoto2Camera(library_, address, options_));
}

std::unique_ptr<StillCamera> GPhoto2Backend::OpenStillCamera(const DeviceInfo& info) {
  if (info.kind != DeviceKind::kStillCamera) {
    throw InvalidArgumentError("gphoto2 device '" + info.id + "' is not a still camera");
  }
  return Open(AddressFromId(info));
}

std::unique_ptr<RgbdSensor> GPhoto2Backend::OpenRgbdSensor(const DeviceInfo& info) {
  throw InvalidArgumentError("gphoto2 device '" + info.id +
                             "' is a still camera; libgphoto2 drives no depth sensors (use the openni2 backend)");
}

// ---- camera ---------------------------------------------------------------------------------

struct GPhoto2Camera::State {
  std::shared_ptr<GPhoto2Backend::Library> library;
  Camera* camera = nullptr;
  Context context;
  bool delete_after_download = true;

  ~State() {
    if (camera != nullptr) {
      gp_camera_exit(camera, context.get());
      gp_camera_unref(camera);
    }
  }

  // The whole configuration tree; the caller frees it with gp_widget_free.
  CameraWidget* GetConfig(const std::string& device_id) {
    CameraWidget* root = nullptr;
    const int result = gp_camera_get_config(camera, &root, context.get());
    if (result < GP_OK) ThrowGphoto(result, device_id, "reading the configuration", context);
    return root;
  }
};

namespace {
// Owns a configuration tree.
struct WidgetTree {
  CameraWidget* root = nullptr;
  ~WidgetTree() {
    if (root != nullptr) gp_widget_free(root);
  }
  CameraWidget* Find(const std::string& name) const {
    CameraWidget* widget = nullptr;
    if (gp_widget_get_child_by_name(root, name.c_str(), &widget) < GP_OK) return nullptr;
    return widget;
  }
};

const char* SettingName(ValueKind kind) {
  switch (kind) {
    case ValueKind::kShutterSpeed: return "shutterspeed";
    case ValueKind::kAperture: return "aperture";
    case ValueKind::kIso: return "iso";
    case ValueKind::kEvCompensation: return "exposurecompensation";
  }
  return "";
}

std::string JoinChoices(const std::vector<std::string>& choices) {
  std::string out;
  for (const std::string& choice : choices) out += (out.empty() ? "" : ", ") + choice;
  return out;
}
}  // namespace

GPhoto2Camera::GPhoto2Camera(std::shared_ptr<GPhoto2Backend::Library> library, const GPhoto2CameraAddress& address,
                             const GPhoto2BackendOptions& options)
    : state_(std::make_unique<State>()), info_(MakeInfo(address)) {
  state_->library = std::move(library);
  state_->delete_after_download = options.delete_after_download;
  const std::string& id = info_.FullId();
  const int model_index = gp_abilities_list_lookup_model(state_->library->abilities, address.model.c_str());
  if (model_index < GP_OK) {
    throw DeviceError(DeviceErrorKind::kNotFound, id,
                      "no camera driver knows the model '" + address.model +
                          "' (check the spelling against `gphoto2 --list-cameras`, or the CAMLIBS folder)");
  }
  const int port_index = gp_port_info_list_lookup_path(state_->library->ports, address.port.c_str());
  if (port_index < GP_OK) {
    throw DeviceError(DeviceErrorKind::kNotFound, id,
                      "no port '" + address.port + "' (see `gphoto2 --list-ports`; is the port driver installed?)");
  }
  CameraAbilities abilities;
  gp_abilities_list_get_abilities(state_->library->abilities, model_index, &abilities);
  GPPortInfo port_info;
  gp_port_info_list_get_info(state_->library->ports, port_index, &port_info);
  gp_camera_new(&state_->camera);
  gp_camera_set_abilities(state_->camera, abilities);
  gp_camera_set_port_info(state_->camera, port_info);
  const int result = gp_camera_init(state_->camera, state_->context.get());
  if (result < GP_OK) {
    gp_camera_unref(state_->camera);
    state_->camera = nullptr;
    ThrowGphoto(result, id, "opening the camera", state_->context, /*opening=*/true);
  }
  info_.details["driver_status"] = abilities.status == GP_DRIVER_STATUS_PRODUCTION ? "production" : "testing";
  if (!options.capture_target.empty()) SetConfigValue("capturetarget", options.capture_target);
  RefreshFromConfig();
}

GPhoto2Camera::~GPhoto2Camera() = default;

void GPhoto2Camera::RefreshFromConfig() {
  WidgetTree tree{state_->GetConfig(info_.FullId())};
  capabilities_ = {};
  const auto choices_of = [&](ValueKind kind) {
    CameraWidget* widget = tree.Find(SettingName(kind));
    return widget != nullptr ? WidgetChoices(widget) : std::vector<std::string>{};
  };
  capabilities_.shutter_speeds_s = NumericChoices(ValueKind::kShutterSpeed, choices_of(ValueKind::kShutterSpeed));
  capabilities_.apertures_f = NumericChoices(ValueKind::kAperture, choices_of(ValueKind::kAperture));
  capabilities_.iso_values = NumericChoices(ValueKind::kIso, choices_of(ValueKind::kIso));
  capabilities_.ev_steps = NumericChoices(ValueKind::kEvCompensation, choices_of(ValueKind::kEvCompensation));
  capabilities_.control = capabilities_.shutter_speeds_s.empty() && !capabilities_.ev_steps.empty()
                              ? ExposureControl::kEvOnly
                              : ExposureControl::kShutterList;
  const auto value_of = [&](ValueKind kind) -> double {
    CameraWidget* widget = tree.Find(SettingName(kind));
    if (widget == nullptr) return NAN;
    return ParseValue(kind, WidgetValue(widget)).value_or(NAN);
  };
  current_ = {};
  current_.exposure_time_s = value_of(ValueKind::kShutterSpeed);
  current_.aperture_f = value_of(ValueKind::kAperture);
  current_.iso = value_of(ValueKind::kIso);
  const double ev = value_of(ValueKind::kEvCompensation);
  current_.ev_compensation = std::isnan(ev) ? 0.0 : ev;
  for (const char* name : {"serialnumber", "eosserialnumber"}) {
    if (CameraWidget* widget = tree.Find(name)) info_.serial = WidgetValue(widget);
  }
  if (CameraWidget* widget = tree.Find("capturetarget")) info_.details["capturetarget"] = WidgetValue(widget);
}

void GPhoto2Camera::Apply(const ExposureSettings& settings) {
  const std::string& id = info_.FullId();
  if (settings.gain_db) {
    throw DeviceError(DeviceErrorKind::kUnsupportedSetting, id, "gain_db cannot be set on a gphoto2 camera (use iso)");
  }
  WidgetTree tree{state_->GetConfig(id)};
  // Validate everything first, so that a bad value changes nothing.
  std::vector<std::pair<CameraWidget*, std::string>> changes;
  const auto plan = [&](ValueKind kind, const std::optional<double>& value) {
    if (!value) return;
    CameraWidget* widget = tree.Find(SettingName(kind));
    if (widget == nullptr) {
      throw DeviceError(DeviceErrorKind::kUnsupportedSetting, id,
                        std::string("the camera has no '") + SettingName(kind) + "' setting");
    }
    int readonly = 0;
    gp_widget_get_readonly(widget, &readonly);
    const std::vector<std::string> choices = WidgetChoices(widget);
    const int index = MatchChoice(kind, choices, *value);
    if (readonly || index < 0) {
      std::ostringstream what;
      what << SettingName(kind) << " " << *value << " is not offered"
           << (readonly ? " (the setting is read-only in the camera's current mode)" : "")
           << "; the camera offers: " << JoinChoices(choices);
      throw DeviceError(DeviceErrorKind::kUnsupportedSetting, id, what.str());
    }
    changes.emplace_back(widget, choices[static_cast<std::size_t>(index)]);
  };
  plan(ValueKind::kShutterSpeed, settings.exposure_time_s);
  plan(ValueKind::kAperture, settings.aperture_f);
  plan(ValueKind::kIso, settings.iso);
  plan(ValueKind::kEvCompensation, settings.ev_compensation);
  if (changes.empty()) return;
  for (const auto& [widget, value] : changes) gp_widget_set_value(widget, value.c_str());
  const int result = gp_camera_set_config(state_->camera, tree.root, state_->context.get());
  if (result < GP_OK) ThrowGphoto(result, id, "setting exposure", state_->context);
  for (const auto& [widget, value] : changes) {
    const char* name = nullptr;
    gp_widget_get_name(widget, &name);
    const std::string key = name != nullptr ? name : "";
    if (key == "shutterspeed") current_.exposure_time_s = ParseShutterSpeedS(value).value_or(NAN);
    if (key == "aperture") current_.aperture_f = ParseApertureF(value).value_or(NAN);
    if (key == "iso") current_.iso = ParseIso(value).value_or(NAN);
    if (key == "exposurecompensation") current_.ev_compensation = ParseEvCompensation(value).value_or(0.0);
  }
}

StillFrame GPhoto2Camera::Capture() {
  const std::string id = info_.FullId();
  CameraFilePath path;
  int result = gp_camera_capture(state_->camera, GP_CAPTURE_IMAGE, &path, state_->context.get());
  if (result < GP_OK) ThrowGphoto(result, id, "capturing", state_->context);
  CameraFile* file = nullptr;
  gp_file_new(&file);
  result = gp_camera_file_get(state_->camera, path.folder, path.name, GP_FILE_TYPE_NORMAL, file, state_->context.get());
  if (result < GP_OK) {
    gp_file_unref(file);
    ThrowGphoto(result, id, std::string("downloading ") + path.folder + "/" + path.name, state_->context);
  }
  StillFrame frame;
  frame.timing.host_utc = UtcNow();
  frame.timing.host_monotonic = MonotonicNow();
  frame.timing.sequence = ++sequence_;
  const char* data = nullptr;
  unsigned long size = 0;
  gp_file_get_data_and_size(file, &data, &size);
  const char* mime = nullptr;
  gp_file_get_mime_type(file, &mime);
  frame.original_file.assign(reinterpret_cast<const std::uint8_t*>(data),
                             reinterpret_cast<const std::uint8_t*>(data) + size);
  frame.original_format = FileFormat(path.name, mime != nullptr ? mime : "");
  gp_file_unref(file);
  if (state_->delete_after_download) {
    // The frame is good even when the camera refuses to delete it: keep the frame, and say so
    // in the device details (a camera whose RAM fills up fails its next capture clearly).
    result = gp_camera_file_delete(state_->camera, path.folder, path.name, state_->context.get());
    if (result < GP_OK) {
      info_.details["last_delete_error"] = std::string(path.name) + ": " + gp_result_as_string(result);
      state_->context.TakeMessages();
    }
  }
  if (frame.original_file.empty()) {
    throw DeviceError(DeviceErrorKind::kCorruptFrame, id, std::string("the camera sent an empty file ") + path.name);
  }
  frame.device_id = id;
  frame.model = info_.model;
  frame.exposure = current_;
  if (IsRawFormat(frame.original_format)) {
    try {
      frame.image = DecodeRawFile(frame.original_file, id + " " + path.name).image;
    } catch (const Error& e) {
      frame.undecoded_reason = e.what();  // the camera's file is still delivered
    }
  } else {
    const cv::Mat decoded = cv::imdecode(frame.original_file, cv::IMREAD_UNCHANGED);
    if (decoded.empty()) {
      throw DeviceError(DeviceErrorKind::kCorruptFrame, id,
                        std::string("cannot decode ") + path.name + " (" + frame.original_format + ")");
    }
    CameraImage& image = frame.image;
    const bool sixteen = decoded.depth() == CV_16U;
    if (decoded.channels() == 1) {
      image.pixels = decoded;
      image.layout = ColorLayout::kMono;
    } else {
      cv::cvtColor(decoded, image.pixels, decoded.channels() == 4 ? cv::COLOR_BGRA2RGB : cv::COLOR_BGR2RGB);
      image.layout = ColorLayout::kRgb;
    }
    if (!sixteen && decoded.depth() != CV_8U) {
      throw DeviceError(DeviceErrorKind::kCorruptFrame, id, std::string("unexpected sample type in ") + path.name);
    }
    image.encoding = SampleEncoding::kCameraResponse;
    image.bits_per_sample = sixteen ? 16 : 8;
    image.black_level = 0;
    image.white_level = sixteen ? 65535 : 255;
  }
  return frame;
}

std::vector<std::string> GPhoto2Camera::ConfigNames() {
  WidgetTree tree{state_->GetConfig(info_.FullId())};
  std::vector<std::string> names;
  CollectLeafNames(tree.root, &names);
  return names;
}

std::string GPhoto2Camera::GetConfigValue(const std::string& name) {
  WidgetTree tree{state_->GetConfig(info_.FullId())};
  CameraWidget* widget = tree.Find(name);
  if (widget == nullptr) {
    throw DeviceError(DeviceErrorKind::kUnsupportedSetting, info_.FullId(), "the camera has no '" + name + "' setting");
  }
  return WidgetValue(widget);
}

std::vector<std::string> GPhoto2Camera::ConfigChoices(const std::string& name) {
  WidgetTree tree{state_->GetConfig(info_.FullId())};
  CameraWidget* widget = tree.Find(name);
  if (widget == nullptr) {
    throw DeviceError(DeviceErrorKind::kUnsupportedSetting, info_.FullId(), "the camera has no '" + name + "' setting");
  }
  return WidgetChoices(widget);
}

void GPhoto2Camera::SetConfigValue(const std::string& name, const std::string& value) {
  const std::string id = info_.FullId();
  WidgetTree tree{state_->GetConfig(id)};
  CameraWidget* widget = tree.Find(name);
  if (widget == nullptr) {
    throw DeviceError(DeviceErrorKind::kUnsupportedSetting, id, "the camera has no '" + name + "' setting");
  }
  int readonly = 0;
  gp_widget_get_readonly(widget, &readonly);
  if (readonly) throw DeviceError(DeviceErrorKind::kUnsupportedSetting, id, "'" + name + "' is read-only");
  CameraWidgetType type;
  gp_widget_get_type(widget, &type);
  int set = GP_OK;
  switch (type) {
    case GP_WIDGET_RADIO:
    case GP_WIDGET_MENU: {
      const std::vector<std::string> choices = WidgetChoices(widget);
      if (std::find(choices.begin(), choices.end(), value) == choices.end()) {
        throw DeviceError(
            DeviceErrorKind::kUnsupportedSetting, id,
            "'" + value + "' is not a choice of '" + name + "'; the camera offers: " + JoinChoices(choices));
      }
      set = gp_widget_set_value(widget, value.c_str());
      break;
    }
    case GP_WIDGET_TEXT: set = gp_widget_set_value(widget, value.c_str()); break;
    case GP_WIDGET_TOGGLE: {
      if (value != "0" && value != "1") {
        throw DeviceError(DeviceErrorKind::kUnsupportedSetting, id, "'" + name + "' is a toggle: give 0 or 1");
      }
      const int on = value == "1" ? 1 : 0;
      set = gp_widget_set_value(widget, &on);
      break;
    }
    case GP_WIDGET_RANGE: {
      float low = 0.0f, high = 0.0f, step = 0.0f;
      gp_widget_get_range(widget, &low, &high, &step);
      char* end = nullptr;
      const float number = std::strtof(value.c_str(), &end);
      if (value.empty() || *end != '\0' || number < low || number > high) {
        std::ostringstream what;
        what << "'" << value << "' is outside the range of '" << name << "' [" << low << ", " << high << "]";
        throw DeviceError(DeviceErrorKind::kUnsupportedSetting, id, what.str());
      }
      set = gp_widget_set_value(widget, &number);
      break;
    }
    default: throw DeviceError(DeviceErrorKind::kUnsupportedSetting, id, "'" + name + "' cannot be set by value here");
  }
  if (set < GP_OK) ThrowGphoto(set, id, "setting " + name, state_->context);
  const int result = gp_camera_set_config(state_->camera, tree.root, state_->context.get());
  if (result < GP_OK) ThrowGphoto(result, id, "setting " + name, state_->context);
  if (name == "shutterspeed" || name == "aperture" || name == "iso" || name == "exposurecompensation" ||
      name == "capturetarget") {
    gp_widget_free(tree.root);
    tree.root = nullptr;
    RefreshFromConfig();
  }
}

}  // namespace relume::drivers::gphoto2
