#include "orpe/pipeline/config.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <filesystem>
#include <fstream>

#include "orpe/core/error.h"
#include "orpe/core/params_io.h"

namespace orpe {

bool OrpeConfig::IsValid(std::string* why) const {
  bool ok = true;
  const_cast<OrpeConfig*>(this)->visit_sections([&](const char* name, const auto& params) {
    if (!ok) return;
    std::string reason;
    if (!params.IsValid(&reason)) {
      ok = false;
      if (why) *why = std::string(name) + ": " + reason;
    }
  });
  return ok;
}

namespace {

/// A section name or a key: a list or a map there is an error naming its line (yaml-cpp's
/// as<std::string>() throws a bare BadConversion for it: fuzz config_json finding 31).
std::string yaml_name(const YAML::Node& node, const std::string& path, const std::string& what) {
  if (node.IsMap() || node.IsSequence())
    throw IoError(path, fmt::format("line {}: {} must be a plain word, not a list or a map",
                                    node.Mark().line + 1, what));
  return node.as<std::string>();
}

/// A YAML config: the same sections and keys as JSON, every value a scalar parsed by the key's type
/// exactly as `--set` parses it (so `scene: 0001` stays the string "0001"). Errors name the line.
void load_yaml_config(OrpeConfig& config, const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw IoError(path, "cannot open config file");
  } catch (const YAML::Exception& e) {
    throw IoError(path, fmt::format("line {}: invalid YAML: {}", e.mark.line + 1, e.msg));
  }
  if (root.IsNull()) return;
  if (!root.IsMap()) throw IoError(path, "config must be a YAML mapping of sections");
  for (const auto& section : root) {
    const std::string name = yaml_name(section.first, path, "a section name");
    const int line = section.first.Mark().line + 1;
    bool found = false;
    config.visit_sections([&](const char* section_name, auto& params) {
      if (name != section_name) return;
      found = true;
      if (!section.second.IsMap())
        throw IoError(path,
                      fmt::format("line {}: section '{}' must be a mapping of keys", line, name));
      for (const auto& kv : section.second) {
        const std::string key = yaml_name(kv.first, path, "a key of section '" + name + "'");
        const int key_line = kv.first.Mark().line + 1;
        if (!kv.second.IsScalar())
          throw IoError(
              path, fmt::format("line {}: '{}.{}' must be a single value", key_line, name, key));
        try {
          if (!params_set(params, key, kv.second.Scalar(), name))
            throw ConfigError(unknown_config_key_message(name, key, params_keys(params)));
        } catch (const ConfigError& e) {
          throw IoError(path, fmt::format("line {}: {}", key_line, e.what()));
        }
      }
    });
    if (!found)
      throw IoError(path, fmt::format("line {}: unknown config section '{}'", line, name));
  }
}

bool is_yaml_path(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext == ".yaml" || ext == ".yml";
}

}  // namespace

void load_config_file(OrpeConfig& config, const std::string& path) {
  if (is_yaml_path(path)) return load_yaml_config(config, path);
  std::ifstream is(path);
  if (!is) throw IoError(path, "cannot open config file");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(is);
  } catch (const std::exception& e) {
    throw IoError(path, std::string("invalid JSON: ") + e.what());
  }
  if (!j.is_object()) throw IoError(path, "config must be a JSON object of sections");
  for (auto it = j.begin(); it != j.end(); ++it) {
    bool found = false;
    config.visit_sections([&](const char* name, auto& params) {
      if (it.key() != name) return;
      found = true;
      try {
        params_from_json(params, it.value(), name);
      } catch (const ConfigError& e) {
        throw IoError(path, e.what());
      }
    });
    if (!found) throw IoError(path, "unknown config section '" + it.key() + "'");
  }
}

void apply_config_override(OrpeConfig& config, const std::string& assignment) {
  const auto eq = assignment.find('=');
  const auto dot = assignment.find('.');
  if (eq == std::string::npos || dot == std::string::npos || dot > eq)
    throw ConfigError("override '" + assignment + "' must look like section.key=value");
  const std::string section = assignment.substr(0, dot);
  const std::string key = assignment.substr(dot + 1, eq - dot - 1);
  const std::string value = assignment.substr(eq + 1);
  bool section_found = false, key_found = false;
  std::vector<std::string> known_keys;
  config.visit_sections([&](const char* name, auto& params) {
    if (section != name) return;
    section_found = true;
    key_found = params_set(params, key, value, section);
    if (!key_found) known_keys = params_keys(params);
  });
  if (!section_found)
    throw ConfigError("unknown config section '" + section + "' in '" + assignment + "'");
  if (!key_found) throw ConfigError(unknown_config_key_message(section, key, known_keys));
}

std::vector<ParamDoc> describe_config(const OrpeConfig& config) {
  std::vector<ParamDoc> out;
  OrpeConfig copy = config;
  copy.visit_sections([&](const char* name, auto& params) { params_docs(params, name, out); });
  return out;
}

std::string config_to_json(const OrpeConfig& config) {
  nlohmann::json j = nlohmann::json::object();
  OrpeConfig copy = config;
  copy.visit_sections([&](const char* name, auto& params) { j[name] = params_to_json(params); });
  return j.dump(2);
}

}  // namespace orpe

namespace orpe {

std::vector<std::string> config_preset_names() {
  return {"default", "realtime"};
}

void apply_config_preset(OrpeConfig& config, const std::string& name) {
  if (name == "default") {
    config = OrpeConfig();
  } else if (name == "realtime") {
    config.slam_tracking.level0_pixel_step = 2;
    config.slam_tracking.iterations_level0 = 5;
    // With the prediction at half resolution, level 1 aligns against the same model pixels as
    // level 0 does: one iteration there instead of five (7-Scenes ATE 0.0396 -> 0.0391 m, session 26).
    config.slam_tracking.iterations_level1 = 1;
    // A level stops once an update (m, rad) is below 1e-4 instead of 1e-5: 7-Scenes ATE 0.0391 -> 0.0393 m.
    config.slam_tracking.convergence_step = 1e-4;
    config.slam_fusion.fusion_level = 1;
    config.slam_loop.enabled = false;
    // The surface band's second splatting pass costs ~20 ms per frame; its half-resolution map's
    // surfels are less noisy and gain little from it (docs/SLAM.md, session 23).
    config.slam.prediction_surface_band_m = 0;
  } else {
    throw ConfigError("unknown preset '" + name + "' (known: default, realtime)");
  }
}

}  // namespace orpe
