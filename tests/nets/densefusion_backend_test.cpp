// The `densefusion` pose back-end (orpe/nets/densefusion_estimator.h): the reference evaluation's
// input contract (box snapping, chosen points, cloud, ImageNet normalisation of the 0..255 crop),
// the pose it reports = the network's pose() on that input, the errors (missing / incompatible
// model file, class count, bad inputs), and `orpe run --mode full --set pose.backend=densefusion`
// on a synthetic scene with the map-rendered PM / PD / PC inputs reaching the network.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>

#include "nets/net_fixtures.h"
#include "orpe/core/error.h"
#include "orpe/nets/densefusion_estimator.h"
#include "pipeline/pipeline_test_util.h"
#include "support/cli_run.h"
#include "support/test_data.h"

namespace orpe {
namespace {

MaskImage box_mask(int w, int h, int u0, int v0, int u1, int v1) {
  MaskImage m(w, h, 0);
  for (int v = v0; v < v1; ++v)
    for (int u = u0; u < u1; ++u) m.at(u, v) = 1;
  return m;
}

TEST(densefusion_backend, SnapsTheBoxAsTheReference) {
  // 30 rows x 50 columns -> 40 x 80, centred: rows 10..40 -> centre 25 -> 5..45.
  nets::CropBox b = nets::densefusion_box(box_mask(320, 240, 100, 10, 150, 40));
  EXPECT_EQ(b.rmin, 5);
  EXPECT_EQ(b.rmax, 45);
  EXPECT_EQ(b.cmin, 125 - 40);
  EXPECT_EQ(b.cmax, 125 + 40);
  // A size equal to a border is kept (strict comparisons): 40 rows stay 40.
  b = nets::densefusion_box(box_mask(320, 240, 100, 50, 140, 90));
  EXPECT_EQ(b.height(), 40);
  EXPECT_EQ(b.width(), 40);
  // At the border: shifted inside the image, size kept.
  b = nets::densefusion_box(box_mask(320, 240, 0, 230, 10, 240));
  EXPECT_EQ(b.rmax, 240);
  EXPECT_EQ(b.height(), 40);
  EXPECT_EQ(b.cmin, 0);
  // Larger than a small image: the image's size rounded down to a multiple of 8.
  b = nets::densefusion_box(box_mask(60, 45, 0, 0, 60, 45));
  EXPECT_EQ(b.height(), 40);
  EXPECT_EQ(b.width(), 56);
  EXPECT_EQ(nets::densefusion_box(MaskImage(20, 20, 0)).height(), 0);
}

struct Scene {
  MaskImage mask;
  DepthImage depth;
  ColorImage color;
  ObjectModel model;
  SingleViewInput input;
};

/// A 96 x 72 frame: a textured fronto-parallel patch at 0.7 m masked by a 30 x 20 box, some
/// pixels without depth; the model a 6 cm square.
void make_scene(Scene* s) {
  const int w = 96, h = 72;
  s->mask = box_mask(w, h, 30, 20, 60, 40);
  s->depth = DepthImage(w, h, 0.f);
  s->color = ColorImage(w, h);
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      s->depth.at(u, v) = (u + v) % 7 == 0 ? 0.f : 0.7f + 0.001f * float(u % 5);
      s->color.at(u, v) = Rgb8{std::uint8_t(3 * u), std::uint8_t(2 * v), std::uint8_t(u * v % 251)};
    }
  for (int i = -10; i <= 10; ++i)
    for (int j = -10; j <= 10; ++j) s->model.points.emplace_back(0.003f * i, 0.003f * j, 0.f);
  s->model.class_id = 2;
  s->model.diameter_m = 0.085;
  prepare_object_model(s->model);
  SingleViewInput& in = s->input;
  in.mask = &s->mask;
  in.depth = &s->depth;
  in.color = &s->color;
  in.intrinsics.width = w;
  in.intrinsics.height = h;
  in.intrinsics.fx = in.intrinsics.fy = 100;
  in.intrinsics.cx = 47.5;
  in.intrinsics.cy = 35.5;
  in.class_id = 2;
  in.model = &s->model;
}

TEST(densefusion_backend, BuildsTheReferenceInput) {
  Scene s;
  make_scene(&s);
  nets::DenseFusionInput d;
  std::string why;
  ASSERT_TRUE(nets::make_densefusion_input(s.input, 100, 10, 1, &d, &why)) << why;
  EXPECT_EQ(d.box.height(), 40);  // 20 rows -> 40; 30 columns -> 40
  EXPECT_EQ(d.box.width(), 40);
  const int bw = d.box.width();
  ASSERT_EQ(d.choose.size(), 100u);
  ASSERT_EQ(d.cloud.size(), 300u);
  EXPECT_GT(d.valid_pixels, 500);  // 600 pixels, 1 in 7 without depth
  EXPECT_LT(d.valid_pixels, 600);
  for (size_t k = 0; k < d.choose.size(); ++k) {
    const int u = d.box.cmin + int(d.choose[k] % bw), v = d.box.rmin + int(d.choose[k] / bw);
    ASSERT_TRUE(s.mask.at(u, v) && s.depth.at(u, v) > 0) << u << "," << v;
    if (k > 0) {
      EXPECT_LT(d.choose[k - 1], d.choose[k]);  // a subset in image order
    }
    const float z = s.depth.at(u, v);
    EXPECT_FLOAT_EQ(d.cloud[3 * k + 2], z);
    EXPECT_NEAR(d.cloud[3 * k], (u - 47.5) * z / 100, 1e-6);
    EXPECT_NEAR(d.cloud[3 * k + 1], (v - 35.5) * z / 100, 1e-6);
  }
  // ImageNet normalisation of the 0..255 values (as the reference's dataset and evaluation).
  const Rgb8 c = s.color.at(d.box.cmin + 3, d.box.rmin + 2);
  const size_t at = 2 * bw + 3, plane = size_t(bw) * d.box.height();
  EXPECT_NEAR(d.crop_chw[at], (c.r - 0.485f) / 0.229f, 1e-3);
  EXPECT_NEAR(d.crop_chw[plane + at], (c.g - 0.456f) / 0.224f, 1e-3);
  EXPECT_NEAR(d.crop_chw[2 * plane + at], (c.b - 0.406f) / 0.225f, 1e-3);
  // Deterministic; a different seed picks other pixels.
  nets::DenseFusionInput again, other;
  ASSERT_TRUE(nets::make_densefusion_input(s.input, 100, 10, 1, &again, &why));
  ASSERT_TRUE(nets::make_densefusion_input(s.input, 100, 10, 2, &other, &why));
  EXPECT_EQ(again.choose, d.choose);
  EXPECT_NE(other.choose, d.choose);
  // Fewer valid pixels than num_points: wrap-padded, every valid pixel once in `points`.
  ASSERT_TRUE(nets::make_densefusion_input(s.input, 1000, 10, 1, &d, &why));
  ASSERT_EQ(d.choose.size(), 1000u);
  EXPECT_EQ(int(d.points.size()), d.valid_pixels);
  EXPECT_EQ(d.choose[d.valid_pixels], d.choose[0]);
}

TEST(densefusion_backend, RefusesBadInputsWithAReason) {
  Scene s;
  make_scene(&s);
  nets::DenseFusionInput d;
  std::string why;
  SingleViewInput in = s.input;
  in.color = nullptr;
  EXPECT_FALSE(nets::make_densefusion_input(in, 100, 10, 1, &d, &why));
  EXPECT_NE(why.find("needs the colour image"), std::string::npos) << why;
  ColorImage small(40, 30);
  in.color = &small;  // another size than mask and depth
  EXPECT_FALSE(nets::make_densefusion_input(in, 100, 10, 1, &d, &why));
  EXPECT_FALSE(why.empty());
  in = s.input;
  EXPECT_FALSE(nets::make_densefusion_input(in, 100, 1000, 1, &d, &why));
  EXPECT_NE(why.find("fewer than densefusion_min_points"), std::string::npos) << why;
  MaskImage tiny(6, 6, 1);
  DepthImage tiny_d(6, 6, 1.f);
  ColorImage tiny_c(6, 6);
  in.mask = &tiny;
  in.depth = &tiny_d;
  in.color = &tiny_c;
  in.intrinsics.width = in.intrinsics.height = 6;
  EXPECT_FALSE(nets::make_densefusion_input(in, 100, 1, 1, &d, &why));
  EXPECT_NE(why.find("smaller than 8 x 8"), std::string::npos) << why;
}

std::map<int, std::string> three_classes() {
  return {{1, "a"}, {2, "b"}, {3, "c"}};
}

PoseBackendParams seeded_params() {
  PoseBackendParams p;
  p.backend = "densefusion";
  p.densefusion_random_seed = 5;
  p.densefusion_num_points = 100;
  p.densefusion_min_points = 10;
  return p;
}

TEST(densefusion_backend, ReportsTheNetworksPoseOnTheCrop) {
  ORPE_REQUIRE_TORCH();
  Scene s;
  make_scene(&s);
  const PoseBackendParams p = seeded_params();
  const nets::DenseFusionEstimator est(p, three_classes());
  EXPECT_EQ(est.network().num_objects(), 3);
  EXPECT_EQ(est.object_index(2), 1);
  const SingleViewPose sv = est.estimate(s.input);
  ASSERT_TRUE(sv.valid) << sv.reason;
  nets::DenseFusionInput d;
  std::string why;
  ASSERT_TRUE(nets::make_densefusion_input(s.input, 100, 10, 1, &d, &why));
  const auto pts = est.network().estimate(d.crop_chw, 40, 40, d.cloud, d.choose, 1);
  const nets::DenseFusionPose ref = est.network().pose(pts, d.cloud, 1, 2);
  const Eigen::Quaterniond q(ref.quaternion[0], ref.quaternion[1], ref.quaternion[2],
                             ref.quaternion[3]);
  EXPECT_LT((sv.T_cam_obj.rotation() - q.toRotationMatrix()).norm(), 1e-9);
  EXPECT_LT((sv.T_cam_obj.translation() -
             Vec3(ref.translation[0], ref.translation[1], ref.translation[2]))
                .norm(),
            1e-9);
  EXPECT_FLOAT_EQ(float(sv.score), *std::max_element(pts.confidence.begin(), pts.confidence.end()));
  EXPECT_DOUBLE_EQ(sv.mu_m, mean_model_distance_m(d.points, s.model, sv.T_cam_obj));
  EXPECT_EQ(sv.num_points, 100);
  // Another class is another head; refinement changes the pose.
  Scene s3;
  make_scene(&s3);
  s3.input.class_id = 3;
  EXPECT_GT((est.estimate(s3.input).T_cam_obj.translation() - sv.T_cam_obj.translation()).norm(),
            1e-6);
  PoseBackendParams p0 = p;
  p0.densefusion_iterations = 0;
  const nets::DenseFusionEstimator unrefined(p0, three_classes());
  EXPECT_GT(
      (unrefined.estimate(s.input).T_cam_obj.translation() - sv.T_cam_obj.translation()).norm(),
      1e-6);
  // The colour inside the box is an input; outside it is not.
  s.color.at(d.box.cmin + 5, d.box.rmin + 5) = Rgb8{255, 0, 255};
  for (int u = 0; u < 10; ++u) s.color.at(u, 70) = Rgb8{0, 255, 0};
  const SingleViewPose recoloured = est.estimate(s.input);
  EXPECT_GT((recoloured.T_cam_obj.translation() - sv.T_cam_obj.translation()).norm(), 1e-9);
  Scene s2;
  make_scene(&s2);
  for (int u = 0; u < 10; ++u) s2.color.at(u, 70) = Rgb8{0, 255, 0};
  EXPECT_EQ(est.estimate(s2.input).T_cam_obj.translation(), sv.T_cam_obj.translation());
  // A class that is not the dataset's: invalid with the reason.
  s2.input.class_id = 9;
  const SingleViewPose bad = est.estimate(s2.input);
  EXPECT_FALSE(bad.valid);
  EXPECT_NE(bad.reason.find("class 9"), std::string::npos) << bad.reason;
}

std::string error_of(const PoseBackendParams& p, const std::map<int, std::string>& classes) {
  try {
    nets::DenseFusionEstimator est(p, classes);
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

TEST(densefusion_backend, ClearErrorsForMissingAndIncompatibleFiles) {
  ORPE_REQUIRE_TORCH();
  const std::string dir = test::scratch_dir("densefusion_backend");
  PoseBackendParams p;
  p.backend = "densefusion";
  p.densefusion_iterations = 0;
  p.densefusion_model = dir + "/missing.pt";
  EXPECT_NE(error_of(p, three_classes()).find("missing.pt: cannot open the model file"),
            std::string::npos)
      << error_of(p, three_classes());
  p.densefusion_model = test::nets_data("maskrcnn_tiny.pt");  // a model, but not a PoseNet
  EXPECT_NE(error_of(p, three_classes())
                .find("maskrcnn_tiny.pt: no tensor conv4_r.weight (not a converted PoseNet"),
            std::string::npos)
      << error_of(p, three_classes());
  p.densefusion_iterations = 2;  // refinement without a refiner file: a config error
  EXPECT_NE(error_of(p, three_classes()).find("needs densefusion_refiner"), std::string::npos);
}

TEST(densefusion_backend, RefusesAClassCountOtherThanTheDatasets) {
  ORPE_REQUIRE_TORCH();
  if (std::system("/usr/bin/python3 -c 'import torch' 2> /dev/null") != 0)
    GTEST_SKIP() << "no /usr/bin/python3 with torch (python3-torch)";
  const std::string dir = test::scratch_dir("densefusion_classes");
  const std::string py =
      "/usr/bin/python3 " + std::string(ORPE_SOURCE_DIR) + "/scripts/nets/densefusion_fixtures.py ";
  // The fixture's 3-class networks in the official checkpoint format, converted.
  ASSERT_EQ(std::system((py + "seeded-checkpoints --names " +
                         test::nets_data("densefusion_small.names.txt") + " --posenet " + dir +
                         "/pose_model.pth --refiner " + dir + "/pose_refine_model.pth && " + py +
                         "convert " + dir + "/pose_model.pth --out " + dir +
                         "/posenet.pt > /dev/null && " + py + "convert " + dir +
                         "/pose_refine_model.pth --out " + dir + "/refiner.pt > /dev/null")
                            .c_str()),
            0);
  PoseBackendParams p;
  p.backend = "densefusion";
  p.densefusion_model = dir + "/posenet.pt";
  p.densefusion_refiner = dir + "/refiner.pt";
  p.densefusion_num_points = 100;
  p.densefusion_min_points = 10;
  const std::string e = error_of(p, {{1, "a"}, {2, "b"}});
  EXPECT_NE(e.find("posenet.pt: the network has 3 object classes, the dataset 2 (a, b)"),
            std::string::npos)
      << e;
  const nets::DenseFusionEstimator est(p, three_classes());  // the right count loads and runs
  Scene s;
  make_scene(&s);
  EXPECT_TRUE(est.estimate(s.input).valid);
  p.densefusion_refiner = dir + "/posenet.pt";  // PoseNet given as the refiner
  EXPECT_NE(
      error_of(p, three_classes()).find("posenet.pt: tensor feat.conv5.weight has another shape"),
      std::string::npos)
      << error_of(p, three_classes());
}

/// single_view.csv rows (after the header) of one variant of a run.
std::vector<std::string> single_view_rows(const std::string& path) {
  std::ifstream is(path);
  EXPECT_TRUE(is.good()) << path;
  std::vector<std::string> rows;
  std::string line;
  std::getline(is, line);
  while (std::getline(is, line)) rows.push_back(line);
  return rows;
}

TEST(densefusion_backend, RunsInsideOrpeRunFullModeOnTheRenderedInputs) {
  ORPE_REQUIRE_TORCH();
  const std::string scene =
      test::synthetic_scene("densefusion", test::small_scene_params(160, 120, 4, 3, 2));
  const std::string dir = test::scratch_dir("densefusion_run");
  const std::string out = dir + "/run";
  ASSERT_EQ(test::run_cli("run --dataset " + scene + " --out " + out +
                          " --mode full --set dataset.last_frame=1"
                          " --ablation DF-PM --ablation DF-PM-PD --ablation DF-PM-PD-PC"
                          " --set pose.backend=densefusion --set pose.densefusion_random_seed=3"
                          " --set pose.densefusion_num_points=100"),
            0);
  const auto summary = test::read_json(out + "/summary.json");
  EXPECT_EQ(summary["config"]["pose"]["backend"].get<std::string>(), "densefusion");
  // The same objects in each configuration; the projected depth (PD) and colour (PC) reach the
  // network: each input change changes its poses (a geometry-only estimator would give DF-PM-PD =
  // DF-PM-PD-PC).
  const auto pm = single_view_rows(out + "/ablation/DF-PM/single_view.csv");
  const auto pd = single_view_rows(out + "/ablation/DF-PM-PD/single_view.csv");
  const auto pc = single_view_rows(out + "/ablation/DF-PM-PD-PC/single_view.csv");
  ASSERT_FALSE(pm.empty());
  ASSERT_EQ(pm.size(), pd.size());
  ASSERT_EQ(pd.size(), pc.size());
  int differ_pd = 0, differ_pc = 0;
  for (size_t i = 0; i < pm.size(); ++i) {
    differ_pd += pm[i] != pd[i];
    differ_pc += pd[i] != pc[i];
  }
  EXPECT_GT(differ_pd, 0);
  EXPECT_GT(differ_pc, 0);
  EXPECT_NE(pc[0].find(",1,"), std::string::npos) << "no valid estimate: " << pc[0];
}

}  // namespace
}  // namespace orpe
