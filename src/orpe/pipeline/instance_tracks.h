// Per-instance state (pose tracks) kept by a later stage must follow the semantic map when it
// merges instances: the state of an absorbed instance moves onto its survivor.
#pragma once

#include <map>
#include <utility>

namespace orpe {

/// Moves every state whose instance id resolves to another id (`resolve(id)`: the survivor of a
/// merge, or id itself) onto that survivor. When the survivor has a state already, the one with the
/// larger `weight(state)` (e.g. views fused) is kept; on a tie the survivor's own. Returns how many
/// states were moved or dropped.
template <class State, class Resolve, class Weight>
int hand_over_merged(std::map<int, State>& states, Resolve&& resolve, Weight&& weight) {
  int handed = 0;
  for (auto it = states.begin(); it != states.end();) {
    const int survivor = resolve(it->first);
    if (survivor == it->first) {
      ++it;
      continue;
    }
    // std::map insertion keeps `it` valid.
    auto [dst, inserted] = states.try_emplace(survivor);
    if (inserted || weight(it->second) > weight(dst->second)) dst->second = std::move(it->second);
    it = states.erase(it);
    ++handed;
  }
  return handed;
}

}  // namespace orpe
