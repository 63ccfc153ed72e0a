#include "orpe/slam/surfel_map.h"

#include <algorithm>
#include <numeric>

namespace orpe::slam {
namespace {

// Applies `f` to every array of the map (keeps the arrays in step in one place).
template <class Map, class F>
void for_each_array(Map& m, F&& f) {
  f(m.position_world);
  f(m.normal_world);
  f(m.color);
  f(m.radius_m);
  f(m.confidence);
  f(m.init_time);
  f(m.last_seen_time);
  f(m.instance_id);
  f(m.p_object);
  f(m.boundary_counter);
  f(m.object_obs_count);
  f(m.always_active);
}

}  // namespace

void SurfelMap::clear() {
  for_each_array(*this, [](auto& a) { a.clear(); });
}

void SurfelMap::reserve(size_t n) {
  for_each_array(*this, [n](auto& a) { a.reserve(n); });
}

void SurfelMap::resize(size_t n) {
  position_world.resize(n, Vec3f::Zero());
  normal_world.resize(n, Vec3f::Zero());
  color.resize(n);
  radius_m.resize(n, 0.0f);
  confidence.resize(n, 0.0f);
  init_time.resize(n, 0);
  last_seen_time.resize(n, 0);
  instance_id.resize(n, 0);
  p_object.resize(n, 0.0f);
  boundary_counter.resize(n, 0);
  object_obs_count.resize(n, 0);
  always_active.resize(n, 0);
}

size_t SurfelMap::push_back(const Surfel& s) {
  position_world.push_back(s.position_world);
  normal_world.push_back(s.normal_world);
  color.push_back(s.color);
  radius_m.push_back(s.radius_m);
  confidence.push_back(s.confidence);
  init_time.push_back(s.init_time);
  last_seen_time.push_back(s.last_seen_time);
  instance_id.push_back(s.instance_id);
  p_object.push_back(s.p_object);
  boundary_counter.push_back(s.boundary_counter);
  object_obs_count.push_back(s.object_obs_count);
  always_active.push_back(s.always_active);
  return size() - 1;
}

Surfel SurfelMap::get(size_t i) const {
  Surfel s;
  s.position_world = position_world[i];
  s.normal_world = normal_world[i];
  s.color = color[i];
  s.radius_m = radius_m[i];
  s.confidence = confidence[i];
  s.init_time = init_time[i];
  s.last_seen_time = last_seen_time[i];
  s.instance_id = instance_id[i];
  s.p_object = p_object[i];
  s.boundary_counter = boundary_counter[i];
  s.object_obs_count = object_obs_count[i];
  s.always_active = always_active[i];
  return s;
}

void SurfelMap::set(size_t i, const Surfel& s) {
  position_world[i] = s.position_world;
  normal_world[i] = s.normal_world;
  color[i] = s.color;
  radius_m[i] = s.radius_m;
  confidence[i] = s.confidence;
  init_time[i] = s.init_time;
  last_seen_time[i] = s.last_seen_time;
  instance_id[i] = s.instance_id;
  p_object[i] = s.p_object;
  boundary_counter[i] = s.boundary_counter;
  object_obs_count[i] = s.object_obs_count;
  always_active[i] = s.always_active;
}

void SurfelMap::remove(std::vector<std::uint32_t> indices, std::vector<std::uint32_t>* moved_from) {
  std::sort(indices.begin(), indices.end());
  indices.erase(std::unique(indices.begin(), indices.end()), indices.end());
  while (!indices.empty() && indices.back() >= size()) indices.pop_back();
  if (moved_from) {
    moved_from->resize(size());
    std::iota(moved_from->begin(), moved_from->end(), 0u);
  }
  // Fill holes from the front with survivors from the back: walk the removal list ascending and
  // take the last element of the array that is not itself being removed.
  size_t n = size();
  size_t hi = indices.size();  // indices[lo..hi) are the removals not yet consumed from the back
  for (size_t lo = 0; lo < hi; ++lo) {
    const size_t hole = indices[lo];
    // Drop trailing elements that are themselves removals.
    while (hi > lo && n > 0 && indices[hi - 1] == n - 1) {
      --hi;
      --n;
    }
    if (lo >= hi) break;
    const size_t src = n - 1;
    if (src <= hole) break;
    for_each_array(*this, [hole, src](auto& a) { a[hole] = a[src]; });
    if (moved_from) (*moved_from)[hole] = (*moved_from)[src];
    --n;
  }
  for_each_array(*this, [n](auto& a) { a.resize(n); });
  if (moved_from) moved_from->resize(n);
}

size_t SurfelMap::bytes() const { return size() * kBytesPerSurfel; }

}  // namespace orpe::slam
