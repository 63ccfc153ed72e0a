// Scale-out (docs/SCALING.md): scripts/run_many.sh runs one `orpe run` per sequence under GNU
// parallel, and `orpe eval poses --result A --result B` merges runs into one table: the same
// figures as one file holding every row; overlapping runs (the same image in two files) refused.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "pipeline/pipeline_test_util.h"
#include "support/cli_run.h"

namespace orpe {
namespace {

/// Splits a BOP results CSV by image id: rows with im_id < split into `a`, the rest into `b`.
void split_results(const std::string& csv, int split, const std::string& a, const std::string& b) {
  std::ifstream is(csv);
  std::ofstream oa(a), ob(b);
  std::string line;
  std::getline(is, line);  // header
  oa << line << "\n";
  ob << line << "\n";
  while (std::getline(is, line)) {
    std::stringstream ss(line);
    std::string scene, im;
    std::getline(ss, scene, ',');
    std::getline(ss, im, ',');
    (std::stoi(im) < split ? oa : ob) << line << "\n";
  }
}

TEST(ScaleOut, EvalMergesResultsFilesIntoTheSameTableAsOneFile) {
  const std::string scene =
      test::synthetic_scene("scale_out", test::small_scene_params(120, 90, 6, 3, 21));
  const std::string dir = test::scratch_dir("scale_out");
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  ASSERT_EQ(test::run_cli("run --mode full --dataset " + scene + " --out " + dir +
                          "/run > /dev/null 2>&1"),
            0);
  const std::string all = dir + "/run/poses.csv";
  split_results(all, 3, dir + "/a.csv", dir + "/b.csv");
  const std::string eval = "eval poses --dataset " + scene + " --json ";
  ASSERT_EQ(test::run_cli(eval + dir + "/one.json --result " + all + " > /dev/null 2>&1"), 0);
  ASSERT_EQ(test::run_cli(eval + dir + "/merged.json --result " + dir + "/a.csv --result " + dir +
                          "/b.csv > /dev/null 2>&1"),
            0);
  const auto one = test::read_json(dir + "/one.json");
  const auto merged = test::read_json(dir + "/merged.json");
  ASSERT_TRUE(one.contains("all")) << one.dump().substr(0, 300);
  EXPECT_EQ(one["all"], merged["all"]);
  EXPECT_EQ(one["classes"], merged["classes"]);
  // Half of the rows alone score lower (the other images' instances count as misses).
  ASSERT_EQ(test::run_cli(eval + dir + "/half.json --result " + dir + "/a.csv > /dev/null 2>&1"),
            0);
  EXPECT_NE(test::read_json(dir + "/half.json")["all"], one["all"]);
  // The same images in two files: refused, naming both.
  const std::string log = dir + "/overlap.log";
  EXPECT_NE(test::run_cli(eval + dir + "/x.json --result " + dir + "/a.csv --result " + all +
                          " 2> " + log + " > /dev/null"),
            0);
  std::ifstream is(log);
  const std::string text((std::istreambuf_iterator<char>(is)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("a.csv"), std::string::npos) << text;
  EXPECT_NE(text.find("poses.csv"), std::string::npos) << text;
  EXPECT_NE(text.find("overlap"), std::string::npos) << text;
}

TEST(ScaleOut, RunManyRunsEverySequenceUnderGnuParallel) {
  if (std::system("command -v parallel > /dev/null 2>&1") != 0)
    GTEST_SKIP() << "GNU parallel is not installed (scripts/install-deps.sh installs it)";
  const std::string dir = test::scratch_dir("run_many");
  std::filesystem::remove_all(dir);
  std::vector<std::string> seqs;
  for (int seed : {31, 32}) {
    const std::string src = test::synthetic_scene("run_many_" + std::to_string(seed),
                                                  test::small_scene_params(120, 90, 4, 2, seed));
    const std::string seq = dir + "/in/seq" + std::to_string(seed);
    std::filesystem::create_directories(dir + "/in");
    std::filesystem::create_directory_symlink(src, seq);
    seqs.push_back(seq);
  }
  const std::string cmd = std::string("ORPE=") + ORPE_CLI_PATH + " bash " + ORPE_SOURCE_DIR +
                          "/scripts/run_many.sh --out " + dir + "/out --jobs 2 " + seqs[0] + " " +
                          seqs[1] + " -- --mode slam > /dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  for (const char* name : {"seq31", "seq32"}) {
    const auto summary = test::read_json(dir + "/out/" + name + "/summary.json");
    EXPECT_EQ(summary["dataset"].value("frames_processed", -1), 4)
        << name << ": " << summary.dump().substr(0, 200);
  }
  // A failing run is reported by a non-zero exit; the other run still completes.
  const std::string bad = std::string("ORPE=") + ORPE_CLI_PATH + " bash " + ORPE_SOURCE_DIR +
                          "/scripts/run_many.sh --out " + dir + "/bad --jobs 2 " + seqs[0] + " " +
                          seqs[1] + " -- --mode slam --set no.such_key=1 > /dev/null 2>&1";
  EXPECT_NE(std::system(bad.c_str()), 0);
  EXPECT_TRUE(std::filesystem::exists(dir + "/bad/joblog.tsv"));
}

}  // namespace
}  // namespace orpe
