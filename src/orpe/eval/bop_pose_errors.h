// The BOP 2019-2023 pose-error functions (Hodan et al., "BOP: Benchmark for 6D Object Pose
// Estimation", ECCV 2018, and the BOP Challenge 2019 rules), defined as bop_toolkit defines them
// (docs/EVALUATION.md, "BOP metrics"):
//   MSSD = min_S max_x || T_est x - T_gt S x ||                 (m; scored as a fraction of the
//                                                                  object diameter)
//   MSPD = min_S max_x || proj(T_est x) - proj(T_gt S x) ||     (pixels; scored x 640 / width)
//   VSD_tau = (#{p in V_est & V_gt : |D_est(p) - D_gt(p)| >= tau} + |V_est xor V_gt|) / |V_est |
//   V_gt|
// where S runs over the model's symmetry transformations (identity, models_info.json discrete
// symmetries, continuous ones discretised), x over the model points, D over distance images (camera
// centre to surface, not z) and V over the visibility masks estimated against the test depth with
// tolerance delta ("bop19" mode: pixels without depth count as visible).
#pragma once

#include <map>
#include <string>
#include <vector>

#include "orpe/core/camera.h"
#include "orpe/core/image.h"
#include "orpe/core/se3.h"

namespace orpe {

struct TriangleMesh;

/// One entry of a BOP models_info.json, in metres.
struct BopModelInfo {
  double diameter_m = 0;
  std::vector<SE3> symmetries_discrete;  ///< as listed (the identity is implied)
  struct Continuous {
    Vec3 axis;      ///< unit axis, model frame
    Vec3 offset_m;  ///< a point on the axis, model frame
  };
  std::vector<Continuous> symmetries_continuous;
};

/// Reads models_info.json (BOP: millimetres; `diameter` required, symmetries optional). Throws
/// IoError naming the file and the object id for a malformed entry.
std::map<int, BopModelInfo> read_bop_models_info(const std::string& path);

/// bop_toolkit's misc.get_symmetry_transformations: the identity and the discrete symmetries, each
/// combined with every step of each continuous symmetry discretised into ceil(pi /
/// max_sym_disc_step) rotations (a point at the diameter's half moves at most max_sym_disc_step x
/// diameter per step).
std::vector<SE3> bop_symmetry_transformations(const BopModelInfo& info,
                                              double max_sym_disc_step = 0.01);

/// Maximum Symmetry-aware Surface Distance (m). `symmetries` must hold at least the identity.
double mssd_m(const std::vector<Vec3>& points_obj, const SE3& T_cam_obj_est,
              const SE3& T_cam_obj_gt, const std::vector<SE3>& symmetries);

/// Maximum Symmetry-aware Projection Distance (pixels).
double mspd_px(const std::vector<Vec3>& points_obj, const PinholeIntrinsics& K,
               const SE3& T_cam_obj_est, const SE3& T_cam_obj_gt,
               const std::vector<SE3>& symmetries);

/// Distance image (camera centre to surface, m) of a depth image (z, m; 0 stays 0).
DepthImage depth_to_distance(const DepthImage& depth, const PinholeIntrinsics& K);

/// VSD for each tau (same units as the depths, metres; multiply BOP's fractions by the diameter).
/// `depth_test` is the test image's depth, `depth_est` / `depth_gt` the model rendered alone at the
/// two poses (all z images of one size, 0 = none). 1 for every tau when both masks are empty.
std::vector<double> vsd_errors(const DepthImage& depth_test, const DepthImage& depth_est,
                               const DepthImage& depth_gt, const PinholeIntrinsics& K,
                               double delta_m, const std::vector<double>& taus_m);

/// The model alone rendered at T_cam_obj: z per pixel (m), 0 = not covered.
DepthImage render_model_depth(const TriangleMesh& mesh, const SE3& T_cam_obj,
                              const PinholeIntrinsics& K);

}  // namespace orpe
