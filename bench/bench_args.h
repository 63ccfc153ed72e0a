// Shared command-line handling of the real-data benchmark programs: where the shared data is
// (ORPE_DATA_DIR, else ../shared/data beside the checkout, as the tests), and the flags they all
// take (--data DIR, --scene ID (repeatable), --set section.key=value). Each program names its own
// extra flags; anything else is an error.
#pragma once

#include <cmath>
#include <cstdlib>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "orpe/core/error.h"
#include "orpe/pipeline/config.h"

namespace orpe::bench {

/// The shared real data's root: $ORPE_DATA_DIR, else ../shared/data.
inline std::string shared_data_dir() {
  if (const char* env = std::getenv("ORPE_DATA_DIR"); env && *env) return env;
  return "../shared/data";
}

struct BenchArgs {
  std::string data = shared_data_dir();      ///< --data
  std::vector<std::string> scenes;           ///< --scene, in order
  OrpeConfig config;                         ///< after every --set
  std::map<std::string, std::string> extra;  ///< the program's own flags: flag -> value

  /// The value of an extra flag, or `fallback` when it was not given.
  std::string get(const std::string& flag, const std::string& fallback) const {
    const auto it = extra.find(flag);
    return it == extra.end() ? fallback : it->second;
  }

  /// An extra flag's value as a number, parsed whole (throws ConfigError naming the flag).
  double number(const std::string& flag, double fallback) const {
    const auto it = extra.find(flag);
    if (it == extra.end()) return fallback;
    char* end = nullptr;
    const double v = std::strtod(it->second.c_str(), &end);
    if (it->second.empty() || *end != '\0' || !std::isfinite(v))
      throw ConfigError("argument " + flag + " " + it->second + ": not a number");
    return v;
  }
};

/// Parses argv; every flag takes one value. Throws ConfigError naming the bad argument, or the
/// configuration's IsValid() message.
inline BenchArgs parse_bench_args(int argc, char** argv, const std::set<std::string>& extra_flags,
                                  OrpeConfig config = {}) {
  BenchArgs args;
  args.config = std::move(config);
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) throw ConfigError("argument " + a + ": a value is missing");
    const std::string value = argv[++i];
    if (a == "--data")
      args.data = value;
    else if (a == "--scene")
      args.scenes.push_back(value);
    else if (a == "--set")
      apply_config_override(args.config, value);
    else if (extra_flags.count(a))
      args.extra[a] = value;
    else
      throw ConfigError("unknown argument " + a);
  }
  std::string why;
  if (!args.config.IsValid(&why)) throw ConfigError(why);
  return args;
}

}  // namespace orpe::bench
