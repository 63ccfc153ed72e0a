// Subcommand registry of the `orpe` CLI. Each cmd_*.cpp registers itself with a static
// CommandRegistrar, so adding a subcommand touches no shared file.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <string>
#include <vector>

#include "orpe/pipeline/config.h"

namespace orpe::cli {

using CommandSetup = std::function<void(CLI::App& root)>;

/// Registers `setup`, called once on the root app; `order` sorts the --help listing.
struct CommandRegistrar {
  CommandRegistrar(int order, CommandSetup setup);
};
std::vector<std::pair<int, CommandSetup>>& command_registry();

/// The process's command line, each argument shell-quoted when it needs it (set by main), for the
/// provenance of outputs.
const std::string& command_line();
void set_command_line(int argc, char** argv);

/// --config FILE and --set section.key=value, shared by every command that runs a stage.
struct ConfigOptions {
  std::string preset;
  std::string config_file;
  std::vector<std::string> overrides;
  std::string models_dir;   ///< --models: dataset.models_dir
  std::string camera_file;  ///< --camera: dataset.camera_file
};
void add_config_options(CLI::App& app, ConfigOptions& options);
/// --models DIR and --camera FILE (dataset.models_dir / dataset.camera_file), for the commands that
/// read a dataset.
void add_dataset_options(CLI::App& app, ConfigOptions& options);
/// Defaults, then the preset, then the file, then the overrides; validated. Throws ConfigError /
/// IoError.
OrpeConfig resolve_config(const ConfigOptions& options);

/// Writes `text` and a newline to `path` atomically (the commands' --json outputs).
void write_text_atomic(const std::string& path, const std::string& text);
/// Throws IoError naming `path` when it is not an existing regular file ("<what> does not exist
/// or is not a file").
void require_file(const std::string& path, const char* what);

}  // namespace orpe::cli
