// Which single-view pose back-end the pipeline runs (config section `pose`), and the settings of
// the learned one. Back-ends:
//   - "model": model-based registration of the object's 3D model (model_registration.h; section
//              pose_registration);
//   - "densefusion": DenseFusion (Wang et al., CVPR 2019) in LibTorch on the CPU, from converted
//              checkpoints (src/orpe/nets/densefusion_estimator.h, docs/NETWORKS.md).
#pragma once

#include <string>

namespace orpe {

struct PoseBackendParams {
  std::string backend = "model";      ///< model | densefusion
  std::string densefusion_model;      ///< converted PoseNet checkpoint (tensors by name)
  std::string densefusion_refiner;    ///< converted PoseRefineNet checkpoint; empty = no refinement
  int densefusion_iterations = 2;     ///< refiner passes (the reference evaluation: 2)
  int densefusion_num_points = 1000;  ///< chosen mask pixels per object (the reference: 1000)
  int densefusion_min_points = 50;    ///< fewer valid-depth mask pixels in the box -> no estimate
  int densefusion_threads = 0;        ///< LibTorch intra-op threads (process-wide); 0 = default
  int densefusion_seed = 1;  ///< seed of the random subset of chosen pixels (deterministic)
  /// >= 0: seeded untrained weights (one head per dataset class) instead of the files, for wiring
  /// tests and timing; -1 = the files.
  int densefusion_random_seed = -1;

  template <class V>
  void visit(V&& v) {
    v("backend", backend,
      "Single-view pose back-end: model (registration of the 3D model, section pose_registration) "
      "| densefusion (DenseFusion in LibTorch, docs/NETWORKS.md)");
    v("densefusion_model", densefusion_model,
      "densefusion: PoseNet file (scripts/nets/densefusion_fixtures.py convert pose_model_*.pth)");
    v("densefusion_refiner", densefusion_refiner,
      "densefusion: PoseRefineNet file (converted pose_refine_model_*.pth); empty = no refinement");
    v("densefusion_iterations", densefusion_iterations,
      "densefusion: refiner iterations (the reference evaluation: 2; needs densefusion_refiner)");
    v("densefusion_num_points", densefusion_num_points,
      "densefusion: mask pixels chosen per object (random subset or wrap-padded; reference 1000)");
    v("densefusion_min_points", densefusion_min_points,
      "densefusion: fewer valid-depth mask pixels in the box give no estimate");
    v("densefusion_threads", densefusion_threads,
      "densefusion: LibTorch intra-op threads (process-wide); 0 = LibTorch's default");
    v("densefusion_seed", densefusion_seed,
      "densefusion: seed of the chosen-pixel subset (the same input gives the same pose)");
    v("densefusion_random_seed", densefusion_random_seed,
      "densefusion: >= 0 = seeded UNTRAINED weights instead of the files (wiring tests, timing); "
      "-1 = the files");
  }

  bool IsValid(std::string* why) const {
    auto fail = [&](const char* reason) {
      if (why) *why = reason;
      return false;
    };
    if (backend != "model" && backend != "densefusion")
      return fail("backend must be model or densefusion");
    const bool files = backend == "densefusion" && densefusion_random_seed < 0;
    if (files && densefusion_model.empty())
      return fail("backend densefusion needs densefusion_model (a converted PoseNet file)");
    if (densefusion_iterations < 0) return fail("densefusion_iterations must be >= 0");
    if (files && densefusion_iterations > 0 && densefusion_refiner.empty())
      return fail("densefusion_iterations > 0 needs densefusion_refiner (or set it to 0)");
    if (densefusion_num_points < 1) return fail("densefusion_num_points must be >= 1");
    if (densefusion_min_points < 1) return fail("densefusion_min_points must be >= 1");
    if (densefusion_threads < 0) return fail("densefusion_threads must be >= 0");
    return true;
  }
};

}  // namespace orpe
