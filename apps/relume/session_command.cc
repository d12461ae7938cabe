#include "apps/relume/session_command.h"

#include <CLI/CLI.hpp>
#include <iostream>
#include <memory>

#include "capture/session_check.h"

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
}

}  // namespace relume::app
