#include "apps/relume/session_command.h"

#include <CLI/CLI.hpp>
#include <iostream>
#include <memory>

#include "capture/scene_model_record.h"
#include "capture/session.h"
#include "capture/session_check.h"
#include "core/scene_model_file.h"
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
}

}  // namespace relume::app
