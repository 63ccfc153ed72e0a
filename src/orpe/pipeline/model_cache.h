// A persistent cache of prepared object models on disk (pipeline.model_cache_dir, issue 15): a
// run that meets a model it prepared before reads it back instead of parsing the mesh, decoding its
// texture, sampling and detecting its symmetry again.
//
// An entry holds what the model files give (ObjectModelLibrary: points, normals, diameter, mean
// spacing, detected symmetry, colour); what the dataset adds (name, symmetric_for_metric, a stated
// symmetry, a colour from pipeline.model_colour_dir) is applied after, on both paths. A model read
// from the cache is bit for bit the one a fresh load gives (numbers as exact text, the colour in
// the colour model format of colour_score.h), and its search index is rebuilt from the points.
//
// An entry is valid while everything it was made from is unchanged: the same format version and
// options (a hash of the load's options), and every input file with the size and modification
// time (ns) it had: the points file, the mesh, its material libraries and texture images (also
// those it looked for and did not find) and the program itself (a rebuilt orpe may prepare models
// differently). Anything else: the model is loaded afresh and the entry rewritten. A corrupt or
// truncated entry (its checksum does not match) is a warning naming the file, then the same.
// Entries are written to a temporary file in the folder and renamed into place, so concurrent runs
// or an interruption never leave half an entry. A folder that cannot be written is one warning per
// cache; the run goes on without storing.
#pragma once

#include <atomic>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "orpe/pose/object_model.h"

namespace orpe {

/// Entry format version: bump it whenever the entry's layout changes.
constexpr int kModelCacheVersion = 1;

/// The folder a pipeline.model_cache_dir setting names: "auto" = $ORPE_CACHE_DIR when set (set but
/// empty: off), else $XDG_CACHE_HOME/orpe/models, else $HOME/.cache/orpe/models (off without
/// $HOME); "" or "none" = off (returns ""); anything else is the folder itself.
std::string resolve_model_cache_dir(const std::string& setting);

/// FNV-1a (64 bit) of `text`, continuing from `seed`; for keys and checksums, not for security.
std::uint64_t fnv1a64(std::string_view text, std::uint64_t seed = 0xcbf29ce484222325ULL);

class ModelCache {
 public:
  /// `dir` = "" turns the cache off (nothing is read or written).
  explicit ModelCache(std::string dir = "") : dir_(std::move(dir)) {}
  bool enabled() const { return !dir_.empty(); }
  const std::string& dir() const { return dir_; }

  /// The entry file of a model: `identity` names its files (what makes two models different),
  /// `options_hash` the options it was prepared with.
  std::string entry_path(const std::string& identity, std::uint64_t options_hash) const;
  /// The model of a valid entry, prepared (search index built); nullopt when there is none, it is
  /// stale, or it is corrupt (then with a warning naming the file). Thread-safe.
  std::optional<ObjectModel> load(const std::string& identity, std::uint64_t options_hash) const;
  /// Writes the entry of `model`, made from `inputs` (paths, in any order, repeats allowed).
  /// A folder that cannot be written: one warning per cache, then nothing. Thread-safe.
  void store(const std::string& identity, std::uint64_t options_hash,
             const std::vector<std::string>& inputs, const ObjectModel& model) const;

 private:
  std::string dir_;
  mutable std::atomic<bool> write_failed_{false};
};

}  // namespace orpe
