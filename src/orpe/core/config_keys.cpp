#include "orpe/core/config_keys.h"

#include <algorithm>
#include <numeric>

namespace orpe {

const std::vector<RenamedConfigKey>& renamed_config_keys() {
  static const std::vector<RenamedConfigKey> table = {
      // 2026-12-07 (session 19)
      {"pose_registration.colour_lambert_fit", "pose_registration.colour_evidence",
       "true -> lambert, false -> ncc; local_contrast is new"},
  };
  return table;
}

std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  std::iota(row.begin(), row.end(), std::size_t{0});
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

std::string unknown_config_key_message(const std::string& section, const std::string& key,
                                       const std::vector<std::string>& known_keys) {
  const std::string full = section + "." + key;
  std::string message = "unknown config key '" + full + "'";
  for (const RenamedConfigKey& r : renamed_config_keys())
    if (full == r.old_key) return message + "; renamed: use '" + r.new_key + "' (" + r.how + ")";
  const std::size_t limit = std::min<std::size_t>(2, key.size() / 3);
  const std::string* best = nullptr;
  std::size_t best_distance = limit + 1;
  for (const std::string& k : known_keys) {  // the first of equally near keys, in visit order
    const std::size_t d = edit_distance(key, k);
    if (d < best_distance) best_distance = d, best = &k;
  }
  if (best) message += "; did you mean '" + section + "." + *best + "'?";
  return message;
}

}  // namespace orpe
