#include "orpe/pipeline/config.h"

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

void load_config_file(OrpeConfig& config, const std::string& path) {
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
  config.visit_sections([&](const char* name, auto& params) {
    if (section != name) return;
    section_found = true;
    key_found = params_set(params, key, value, section);
  });
  if (!section_found) throw ConfigError("unknown config section '" + section + "' in '" + assignment + "'");
  if (!key_found) throw ConfigError("unknown config key '" + section + "." + key + "'");
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

std::vector<std::string> config_preset_names() { return {"default", "realtime"}; }

void apply_config_preset(OrpeConfig& config, const std::string& name) {
  if (name == "default") {
    config = OrpeConfig();
  } else if (name == "realtime") {
    config.slam_tracking.level0_pixel_step = 2;
    config.slam_tracking.iterations_level0 = 5;
    config.slam_fusion.fusion_level = 1;
  } else {
    throw ConfigError("unknown preset '" + name + "' (known: default, realtime)");
  }
}

}  // namespace orpe
