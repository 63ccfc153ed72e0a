// orpe: Object-RPE command-line tool. Subcommands live in cmd_*.cpp.
#include <spdlog/sinks/base_sink.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <iostream>
#include <mutex>

#include "command.h"
#include "orpe/core/atomic_file.h"
#include "orpe/core/error.h"
#include "orpe/core/openmp_waits.h"
#include "orpe/core/version.h"

namespace orpe::cli {

std::vector<std::pair<int, CommandSetup>>& command_registry() {
  static std::vector<std::pair<int, CommandSetup>> registry;
  return registry;
}

CommandRegistrar::CommandRegistrar(int order, CommandSetup setup) {
  command_registry().emplace_back(order, std::move(setup));
}

namespace {
std::string g_command_line;
}  // namespace

const std::string& command_line() {
  return g_command_line;
}

void set_command_line(int argc, char** argv) {
  g_command_line.clear();
  for (int i = 0; i < argc; ++i) {
    const std::string a = argv[i];
    const bool plain = !a.empty() && a.find_first_not_of(
                                         "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                         "0123456789-_./=:,+@%") == std::string::npos;
    std::string quoted = "'";
    for (char c : a) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
    g_command_line += (i ? " " : "") + (plain ? a : quoted + "'");
  }
}

void add_config_options(CLI::App& app, ConfigOptions& options) {
  app.add_option("--preset", options.preset,
                 "Named parameter preset applied first: default, realtime (SLAM >= 15 frames/s; "
                 "docs/SLAM.md)")
      ->check(CLI::IsMember(config_preset_names()));
  app.add_option("--config", options.config_file,
                 "Config file: JSON ({\"section\": {\"key\": value}}) or YAML (.yaml / .yml, "
                 "section: then key: value lines)")
      ->check(CLI::ExistingFile);
  app.add_option("--set", options.overrides,
                 "Override one parameter, section.key=value (repeatable); see `orpe config`");
}

void add_dataset_options(CLI::App& app, ConfigOptions& options) {
  app.add_option("--models", options.models_dir,
                 "Folder of object meshes (one file or folder per object) replacing the dataset's "
                 "models (dataset.models_dir; docs/DATASETS.md)");
  app.add_option(
      "--camera", options.camera_file,
      "Camera YAML (ORB-SLAM2/3 settings or OpenCV style): intrinsics, distortion, depth "
      "scale, depth-to-colour extrinsics; or a sensor preset: kinect_v1, xtion, primesense, "
      "realsense_d435, azure_kinect_720p (dataset.camera_file; docs/DATASETS.md)");
}

OrpeConfig resolve_config(const ConfigOptions& options) {
  OrpeConfig config;
  if (!options.preset.empty()) apply_config_preset(config, options.preset);
  if (!options.config_file.empty()) load_config_file(config, options.config_file);
  for (const auto& o : options.overrides) apply_config_override(config, o);
  if (!options.models_dir.empty()) config.dataset.models_dir = options.models_dir;
  if (!options.camera_file.empty()) config.dataset.camera_file = options.camera_file;
  std::string why;
  if (!config.IsValid(&why)) throw ConfigError("invalid configuration: " + why);
  return config;
}

void write_text_atomic(const std::string& path, const std::string& text) {
  write_file_atomic(path, [&](std::ostream& os) { os << text << "\n"; });
}

void require_file(const std::string& path, const char* what) {
  if (!std::filesystem::is_regular_file(path))
    throw IoError(path, std::string(what) + " does not exist or is not a file");
}

/// Log sink writing warnings and errors to stderr, everything else (progress, results) to stdout.
class SplitStreamSink : public spdlog::sinks::base_sink<std::mutex> {
 protected:
  void sink_it_(const spdlog::details::log_msg& msg) override {
    spdlog::memory_buf_t buf;
    formatter_->format(msg, buf);
    std::FILE* f = msg.level >= spdlog::level::warn ? stderr : stdout;
    if (f == stderr) std::fflush(stdout);  // keep the order of the two streams on a terminal
    std::fwrite(buf.data(), 1, buf.size(), f);
    std::fflush(f);  // progress lines appear when they happen, also in a log file
  }
  void flush_() override {
    std::fflush(stdout);
    std::fflush(stderr);
  }
};

void route_log_streams() {
  auto logger = std::make_shared<spdlog::logger>("orpe", std::make_shared<SplitStreamSink>());
  logger->set_level(spdlog::level::info);
  spdlog::set_default_logger(logger);
}

}  // namespace orpe::cli

int main(int argc, char** argv) {
  using namespace orpe::cli;
  orpe::prefer_passive_openmp_waits(argv);  // docs/PIPELINE.md, "Threads"
  set_command_line(argc, argv);
  CLI::App app{"orpe: object recognition and 6D pose estimation from RGB-D scans (Object-RPE)"};
  app.set_version_flag("--version", std::string("orpe ") + orpe::kVersion);
  app.require_subcommand(1);
  route_log_streams();
  app.add_flag_callback(
      "-v,--verbose", [] { spdlog::set_level(spdlog::level::debug); }, "Debug logging");
  app.add_flag_callback(
      "-q,--quiet", [] { spdlog::set_level(spdlog::level::warn); }, "Warnings and errors only");
  auto& registry = command_registry();
  std::stable_sort(registry.begin(), registry.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  for (auto& [order, setup] : registry) setup(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help / --version exit 0; a bad command line is bad input (docs/CLI.md, exit codes).
    return app.exit(e) == 0 ? 0 : 2;
  } catch (const orpe::Interrupted& e) {
    spdlog::error("{}", e.what());
    return 3;
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
