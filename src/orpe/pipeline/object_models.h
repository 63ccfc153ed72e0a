// The object models of a dataset as the pose stage needs them, loaded on first use per class.
//
// Adapter between DatasetInfo (model_points_paths / model_mesh_paths / symmetric_classes /
// model_units_per_m) and pose/object_model.h, which reads point files (YCB points.xyz) and OBJ meshes:
//  - points file .xyz (YCB-Video): load_object_model with normals from the OBJ mesh when there is one;
//  - points file .ply (BOP, orpe synth): the mesh is read with render/mesh_io (PLY, with faces) and
//    `surface_points` points are sampled uniformly on its triangles (area-weighted, fixed seed) with
//    the face normals; a PLY without faces gives its vertices (normals estimated by PCA).
// The geometric symmetry is detected from the points (pose stage); `symmetric_for_metric` comes from
// the dataset's list. ekf_symmetry() picks the group the pipeline's per-object EKF uses: for BOP
// datasets (and orpe synth scenes) the annotated `symmetries_discrete` / `symmetries_continuous`
// of models/models_info.json when the class has them, since detection from sampled points can miss
// an element (e.g. one of a carton's three 180-degree flips), which leaves two correct measurement
// modes that the EKF's gate treats as disagreeing.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "orpe/io/dataset.h"
#include "orpe/pipeline/model_cache.h"
#include "orpe/pose/object_model.h"

namespace orpe {

/// Loads one class's model as above. Throws IoError naming the file (or the dataset) when the class
/// has no model or the file is bad. With an enabled `cache` (pipeline/model_cache.h) the model
/// comes from its entry when that is valid, else is loaded and stored there: the same model either
/// way, bit for bit.
ObjectModel load_dataset_object_model(const DatasetInfo& info, int class_id,
                                      int surface_points = 2620, const ModelCache* cache = nullptr);

/// The model's minimal width (m): the smallest extent of its points over all directions (1000
/// directions spread evenly on the sphere, then a local search around the best; a box: its
/// smallest side). A resting object's top lies at least this far above its support.
double model_min_width_m(const ObjectModel& model);

class ObjectModelLibrary {
 public:
  explicit ObjectModelLibrary(DatasetInfo info, int surface_points = 2620)
      : info_(std::move(info)), surface_points_(surface_points) {}
  ~ObjectModelLibrary();
  /// True when the dataset lists a model file for the class.
  bool has(int class_id) const { return info_.model_points_paths.count(class_id) > 0; }
  /// The prepared model (loaded on the first call). Throws IoError (see above). Thread-safe.
  const ObjectModel& get(int class_id) const;
  /// Loads the models of `class_ids` not loaded yet on up to `threads` threads (one model per
  /// thread at a time; each model is the one get() would load, so the order and the thread count
  /// change nothing). Throws the IoError of the first class, in `class_ids` order, that failed;
  /// the others are loaded all the same. Thread-safe.
  void preload(const std::vector<int>& class_ids, int threads) const;
  const DatasetInfo& info() const { return info_; }
  /// Colour models to load with the models (pipeline.model_colour_dir): `<dir>/<class name>.colour`
  /// replaces a model's own colour when the file exists. Call before the first get().
  void set_colour_dir(std::string dir) { colour_dir_ = std::move(dir); }
  /// The folder of the on-disk model cache (pipeline/model_cache.h; resolve_model_cache_dir() of
  /// pipeline.model_cache_dir); "" = none (the default). Call before the first get().
  void set_cache_dir(std::string dir);
  /// Class name for messages and outputs ("class <id>" when the dataset has none).
  std::string class_name(int class_id) const;
  /// The symmetry group the EKF uses for the class, by pipeline.ekf_symmetry `mode`: "none" = no
  /// symmetry; "geometric" = the model's detected group; "dataset" = for the dataset's symmetric
  /// classes only: the dataset's annotated group (BOP models_info.json) when it has one, else the
  /// detected group. Throws IoError like get(), and for a malformed models_info.json entry.
  ObjectSymmetry ekf_symmetry(int class_id, const std::string& mode) const;

 private:
  DatasetInfo info_;
  int surface_points_;
  std::string colour_dir_;
  std::unique_ptr<ModelCache> cache_;                     // null = no cache
  std::unique_ptr<ObjectModel> load(int class_id) const;  // the model as get() stores it

  mutable std::mutex mutex_;  // the cache fills lazily behind a const interface
  mutable std::map<int, std::unique_ptr<ObjectModel>> models_;
};

}  // namespace orpe
