#include "rig/session_truth.h"

#include <fstream>
#include <sstream>
#include <utility>

#include "core/error.h"
#include "sim/world/world.h"

namespace relume::rig {
namespace {

class SimSessionTruth final : public SessionTruth {
 public:
  explicit SimSessionTruth(std::shared_ptr<const RigConfig> rig) : rig_(std::move(rig)) {
    std::ostringstream key;
    key << "rig:\n" << rig_->yaml_text << "\nscene:\n";
    std::ifstream scene(rig_->scene_path, std::ios::binary);
    key << scene.rdbuf();
    key_ = key.str();
  }

  GroundTruth Render(const PinholeCamera& camera, UtcTime time) const override {
    return rig_->world->Render(camera, time);
  }

  std::string Key() const override { return key_; }

  std::optional<PinholeCamera> DeviceCamera(const std::string& device_id) const override {
    const std::string id = device_id.starts_with("sim:") ? device_id.substr(4) : device_id;
    for (const sim::SimDeviceSpec& spec : rig_->devices) {
      if (spec.id == id) return spec.camera;
    }
    return std::nullopt;
  }

  std::optional<Eigen::Vector3d> Albedo(const std::string& object, int face) const override {
    const sim::Scene& scene = rig_->world->scene();
    const int index = scene.ObjectIndex(object);
    if (index < 0) return std::nullopt;
    const sim::SceneObject& o = scene.objects[static_cast<std::size_t>(index)];
    const auto f = static_cast<std::size_t>(face);
    if (face >= 0 && f < o.mesh.face_albedo.size() && o.mesh.face_albedo[f].allFinite()) {
      return Eigen::Vector3d(o.mesh.face_albedo[f]);
    }
    return Eigen::Vector3d(o.albedo);
  }

  RadianceImage RenderWithPointLamp(const PinholeCamera& camera, UtcTime time, const Eigen::Vector3d& position_m,
                                    const Eigen::Vector3d& intensity_w_sr) const override {
    sim::Scene scene = rig_->world->scene();
    sim::Lamp lamp;
    lamp.name = "relight";
    lamp.position = position_m;
    lamp.intensity_w_sr = intensity_w_sr;
    scene.lamps = {lamp};
    const sim::World world(scene, rig_->world->options());
    return world.Render(camera, time).radiance;
  }

  Eigen::Vector3d SunDirection(UtcTime time) const override { return rig_->world->SunDirection(time); }

  int IndirectBounces() const override { return rig_->world->options().indirect_bounces; }

 private:
  std::shared_ptr<const RigConfig> rig_;
  std::string key_;
};

}  // namespace

std::shared_ptr<const SessionTruth> MakeSessionTruth(std::shared_ptr<const RigConfig> rig) {
  if (!rig || !rig->world) throw InvalidArgumentError("MakeSessionTruth: the rig has no simulated world");
  return std::make_shared<SimSessionTruth>(std::move(rig));
}

std::shared_ptr<const SessionTruth> LoadSessionTruth(const std::filesystem::path& session_dir) {
  std::shared_ptr<const RigConfig> rig = LoadSessionRig(session_dir);
  if (!rig || !rig->world) return nullptr;
  return MakeSessionTruth(std::move(rig));
}

}  // namespace relume::rig
