// Reflection for Params structs, so that config files, `--set key=value` overrides, `orpe config` and
// the run summary all map onto the same fields without hand-written glue.
//
// A Params struct lists its fields once:
//
//   struct TrackerParams {
//     double icp_max_dist_m = 0.10;
//     template <class V> void visit(V&& v) {
//       v("icp_max_dist_m", icp_max_dist_m, "ICP association: max point distance (m). Typical 0.05-0.2");
//     }
//     bool IsValid(std::string* why) const;
//   };
//
// Supported field types: bool, int, double, float, std::string. Units are part of the key's name.
// Include "orpe/core/params_io.h" (nlohmann-json) only where files or the CLI are handled.
#pragma once

#include <string>
#include <vector>

namespace orpe {

struct ParamDoc {
  std::string key;    ///< "section.field"
  std::string type;   ///< bool | int | double | string
  std::string value;  ///< current value as text
  std::string doc;
};

}  // namespace orpe
