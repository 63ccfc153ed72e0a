// orpe: Object-RPE command-line tool. Subcommands live in cmd_*.cpp.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <exception>
#include <iostream>

#include "command.h"
#include "orpe/core/atomic_file.h"
#include "orpe/core/error.h"
#include "orpe/core/version.h"

namespace orpe::cli {

std::vector<std::pair<int, CommandSetup>>& command_registry() {
  static std::vector<std::pair<int, CommandSetup>> registry;
  return registry;
}

CommandRegistrar::CommandRegistrar(int order, CommandSetup setup) {
  command_registry().emplace_back(order, std::move(setup));
}

void add_config_options(CLI::App& app, ConfigOptions& options) {
  app.add_option("--preset", options.preset,
                 "Named parameter preset applied first: default, realtime (SLAM >= 15 frames/s; "
                 "docs/SLAM.md)")
      ->check(CLI::IsMember(config_preset_names()));
  app.add_option("--config", options.config_file,
                 "JSON config file ({\"section\": {\"key\": value}})")
      ->check(CLI::ExistingFile);
  app.add_option("--set", options.overrides,
                 "Override one parameter, section.key=value (repeatable); see `orpe config`");
}

OrpeConfig resolve_config(const ConfigOptions& options) {
  OrpeConfig config;
  if (!options.preset.empty()) apply_config_preset(config, options.preset);
  if (!options.config_file.empty()) load_config_file(config, options.config_file);
  for (const auto& o : options.overrides) apply_config_override(config, o);
  std::string why;
  if (!config.IsValid(&why)) throw ConfigError("invalid configuration: " + why);
  return config;
}

void write_text_atomic(const std::string& path, const std::string& text) {
  write_file_atomic(path, [&](std::ostream& os) { os << text << "\n"; });
}

}  // namespace orpe::cli

int main(int argc, char** argv) {
  using namespace orpe::cli;
  CLI::App app{"orpe: object recognition and 6D pose estimation from RGB-D scans (Object-RPE)"};
  app.set_version_flag("--version", std::string("orpe ") + orpe::kVersion);
  app.require_subcommand(1);
  bool verbose = false, quiet = false;
  app.add_flag("-v,--verbose", verbose, "Debug logging");
  app.add_flag("-q,--quiet", quiet, "Warnings and errors only");
  auto& registry = command_registry();
  std::stable_sort(registry.begin(), registry.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  for (auto& [order, setup] : registry) setup(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const orpe::IoError& e) {
    spdlog::error("{}", e.what());
    return 2;
  } catch (const orpe::ConfigError& e) {
    spdlog::error("{}", e.what());
    return 2;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
