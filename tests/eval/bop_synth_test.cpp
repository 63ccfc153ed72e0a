// BOP average recall on an `orpe synth` scene (BOP layout): exact poses score 1, a known shift and
// a symmetric flip score what their definitions say, missing estimates count as misses; and the
// CLI (`orpe eval poses --bop`).
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>

#include "orpe/eval/bop_pose_errors.h"
#include "orpe/eval/bop_pose_metrics.h"
#include "orpe/io/bop_results.h"
#include "orpe/io/dataset.h"
#include "orpe/synth/bop_writer.h"
#include "orpe/synth/generator.h"
#include "support/test_data.h"

namespace orpe {
namespace {

struct Scene {
  std::string dir;
  std::unique_ptr<DatasetReader> reader;
  std::map<int, BopModelInfo> info;
  nlohmann::json gt, gt_info;
};

Scene make_scene(const std::string& dir) {
  SynthParams p;
  p.seed = 3;
  p.frames = 2;
  p.objects = 6;
  p.scene = "table";
  p.width = 320;
  p.height = 240;
  p.noise = false;
  p.model_points = 500;
  p.preview_stride = 0;
  synth::SyntheticSceneGenerator(p).write_bop(dir);
  Scene s;
  s.dir = dir;
  s.reader = open_dataset(dir, DatasetParams{});
  s.info = read_bop_models_info(dir + "/models/models_info.json");
  std::ifstream(synth::bop_scene_dir(dir) + "/scene_gt.json") >> s.gt;
  std::ifstream(synth::bop_scene_dir(dir) + "/scene_gt_info.json") >> s.gt_info;
  return s;
}

/// One result row per ground-truth instance, its pose changed by `change(obj_id, T_cam_obj)`;
/// `keep(obj_id)` false drops it.
template <class Change, class Keep>
std::vector<PoseResultRow> rows_from_gt(const Scene& s, Change change, Keep keep) {
  std::vector<PoseResultRow> rows;
  for (size_t i = 0; i < s.reader->size(); ++i) {
    const RgbdFrame f = s.reader->read_annotations(i);
    for (const auto& o : f.objects_gt)
      if (keep(o.class_id))
        rows.push_back({s.reader->info().scene_id, f.index, o.class_id, 1.0,
                        change(o.class_id, o.T_cam_obj), -1});
  }
  return rows;
}

size_t targets_where(const Scene& s, const std::function<bool(int)>& pred) {
  size_t n = 0;
  for (const auto& [im, list] : s.gt.items())
    for (size_t k = 0; k < list.size(); ++k)
      n += s.gt_info[im][k]["visib_fract"].get<double>() >= 0.1 &&
           pred(list[k]["obj_id"].get<int>());
  return n;
}

TEST(BopSynth, ExactShiftedFlippedAndMissingEstimates) {
  const Scene s = make_scene(test::scratch_dir("scene"));
  const BopPoseMetricsParams params;
  auto all = [](int) { return true; };
  auto same = [](int, const SE3& T) { return T; };
  auto eval = [&](const std::vector<PoseResultRow>& rows) {
    return evaluate_bop_pose_results({s.reader.get()}, rows, params);
  };
  const size_t n_targets = targets_where(s, all);
  ASSERT_GT(n_targets, 6u);

  const BopPoseEvaluation exact = eval(rows_from_gt(s, same, all));
  EXPECT_EQ(exact.targets, n_targets);
  EXPECT_DOUBLE_EQ(exact.all.ar_vsd, 1.0);
  EXPECT_DOUBLE_EQ(exact.all.ar_mssd, 1.0);
  EXPECT_DOUBLE_EQ(exact.all.ar_mspd, 1.0);
  EXPECT_DOUBLE_EQ(exact.all.ar, 1.0);

  // Shifted by 0.12 diameters sideways: MSSD = 0.12 diameters, below thresholds 0.15..0.5 only.
  const BopPoseEvaluation shifted = eval(rows_from_gt(
      s,
      [&](int obj, const SE3& T) {
        return SE3(Mat3::Identity(), Vec3(0.12 * s.info.at(obj).diameter_m, 0, 0)) * T;
      },
      all));
  EXPECT_NEAR(shifted.all.ar_mssd, 0.8, 1e-12);
  EXPECT_LT(shifted.all.ar_vsd, 1.0);
  EXPECT_LT(shifted.all.ar_mspd, 1.0);

  // Flipped by each object's first symmetry (every built-in shape has one): as good as exact for
  // MSSD and MSPD; VSD sees the same surface (up to the tessellation at pixel-centre edges).
  const BopPoseEvaluation flipped = eval(rows_from_gt(
      s, [&](int obj, const SE3& T) { return T * s.info.at(obj).symmetries_discrete.at(0); }, all));
  EXPECT_NEAR(flipped.all.ar_mssd, 1.0, 1e-12);
  EXPECT_NEAR(flipped.all.ar_mspd, 1.0, 1e-12);
  EXPECT_GT(flipped.all.ar_vsd, 0.97);
  // ... which the errors without the symmetry would not allow.
  for (const auto& [obj, info] : s.info) {
    const SE3 T(Mat3::Identity(), Vec3(0, 0, 1));
    EXPECT_GT(mssd_m({Vec3(info.diameter_m / 2, 0, 0), Vec3(0, info.diameter_m / 2, 0),
                      Vec3(0, 0, info.diameter_m / 2)},
                     T * info.symmetries_discrete.at(0), T, {SE3()}),
              0.2 * info.diameter_m);
  }

  // Estimates of even obj_ids only: recall = their share of the targets, every threshold.
  const BopPoseEvaluation half = eval(rows_from_gt(s, same, [](int obj) { return obj % 2 == 0; }));
  const double share =
      static_cast<double>(targets_where(s, [](int obj) { return obj % 2 == 0; })) / n_targets;
  EXPECT_NEAR(half.all.ar, share, 1e-12);
  EXPECT_NEAR(half.per_object.at(1).ar, 0.0, 1e-12);
  EXPECT_NEAR(half.per_object.at(2).ar, 1.0, 1e-12);
  // Only the top inst_count estimates per image and object count: a worse-scoring extra estimate
  // of the same instance changes nothing; a better-scoring wrong one takes its place.
  auto rows = rows_from_gt(s, same, all);
  const size_t n_rows = rows.size();
  for (size_t k = 0; k < n_rows; ++k) {
    PoseResultRow wrong = rows[k];
    wrong.T_cam_obj = SE3(Mat3::Identity(), Vec3(0.5, 0, 0)) * wrong.T_cam_obj;
    wrong.score = 0.5;
    rows.push_back(wrong);
  }
  EXPECT_DOUBLE_EQ(eval(rows).all.ar, 1.0);
  for (size_t k = n_rows; k < rows.size(); ++k) rows[k].score = 2.0;
  EXPECT_DOUBLE_EQ(eval(rows).all.ar, 0.0);
}

std::string run_cli(const std::string& args, int* exit_code) {
  std::string out;
  FILE* pipe = popen((std::string(ORPE_CLI_PATH) + " " + args + " 2>&1").c_str(), "r");
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), pipe)) > 0) out.append(buf.data(), n);
  const int status = pclose(pipe);
  *exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return out;
}

TEST(BopSynth, CliPrintsAndWritesTheAverageRecall) {
  const std::string dir = test::scratch_dir("cli");
  const Scene s = make_scene(dir + "/scene");
  write_bop_results(dir + "/exact.csv",
                    rows_from_gt(
                        s, [](int, const SE3& T) { return T; }, [](int) { return true; }));
  int code = 0;
  const std::string out = run_cli(fmt::format("eval poses --dataset {}/scene --result {}/exact.csv "
                                              "--bop --json {}/out.json",
                                              dir, dir, dir),
                                  &code);
  ASSERT_EQ(code, 0) << out;
  EXPECT_NE(out.find("AR_VSD"), std::string::npos) << out;
  EXPECT_NE(out.find("ADD-S AUC"), std::string::npos) << out;
  nlohmann::json j;
  std::ifstream(dir + "/out.json") >> j;
  ASSERT_TRUE(j.contains("bop")) << j.dump();
  EXPECT_DOUBLE_EQ(j["bop"]["ar"].get<double>(), 1.0);
  EXPECT_EQ(j["bop"]["recalls_vsd"].size(), 100u);
  EXPECT_TRUE(j.contains("all"));  // the ADD-S figures stay where they were
  // A dataset without models_info.json: a clear error naming the file.
  std::filesystem::remove(dir + "/scene/models/models_info.json");
  const std::string err = run_cli(fmt::format("eval poses --dataset {}/scene --result {}/exact.csv "
                                              "--bop",
                                              dir, dir),
                                  &code);
  EXPECT_NE(code, 0);
  EXPECT_NE(err.find("models_info.json"), std::string::npos) << err;
}

}  // namespace
}  // namespace orpe
