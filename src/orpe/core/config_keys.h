// What an unknown configuration key is told: the key that replaced it, if it was renamed, or the
// nearest known key of its section, if it looks like a typo.
#pragma once

#include <string>
#include <vector>

namespace orpe {

/// A key that was renamed or replaced in an earlier version: `old_key` ("section.key") is refused
/// with a pointer to `new_key` and `how` (what its values become). Kept so that a config written
/// for an older orpe fails with the way forward, not a bare "unknown key".
struct RenamedConfigKey {
  const char* old_key;
  const char* new_key;
  const char* how;
};

/// Every rename so far, oldest first.
const std::vector<RenamedConfigKey>& renamed_config_keys();

/// "unknown config key 'section.key'", followed by "; renamed: use 'section.new' (...)" when the
/// key was renamed, else "; did you mean 'section.near'?" when one of `known_keys` (the section's
/// keys, without the section) is within a small edit distance of `key` (at most 2, and at most a
/// third of the key's length), else nothing more.
std::string unknown_config_key_message(const std::string& section, const std::string& key,
                                       const std::vector<std::string>& known_keys);

/// Levenshtein distance (insertions, deletions, substitutions; ASCII, case-sensitive).
std::size_t edit_distance(const std::string& a, const std::string& b);

}  // namespace orpe
