#include <gtest/gtest.h>

#include <sys/stat.h>

#include <fstream>

#include "orpe/core/error.h"
#include "orpe/io/bop_results.h"
#include "orpe/io/image_io.h"
#include "orpe/io/model_io.h"
#include "orpe/io/trajectory_io.h"
#include "support/test_data.h"

namespace orpe {
namespace {

TEST(TumTrajectory, RoundTrip) {
  const std::string dir = test::scratch_dir("t");
  std::vector<StampedPose> poses;
  for (int i = 0; i < 5; ++i) {
    Vec6 xi;
    xi << 0.1 * i, -0.2, 0.3, 0.05 * i, 0.1, -0.3;
    poses.push_back({i / 30.0, SE3::exp(xi)});
  }
  write_tum_trajectory(dir + "/traj.txt", poses);
  const auto back = read_tum_trajectory(dir + "/traj.txt");
  ASSERT_EQ(back.size(), poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    EXPECT_NEAR(back[i].timestamp_s, poses[i].timestamp_s, 1e-6);
    EXPECT_LT((back[i].T_world_cam.matrix() - poses[i].T_world_cam.matrix()).norm(), 1e-7);
  }
}

TEST(TumTrajectory, QuaternionOrderIsXyzw) {
  const std::string dir = test::scratch_dir("q");
  std::ofstream(dir + "/t.txt") << "0.0 1 2 3 0 0 0.70710678 0.70710678\n";  // 90 deg about z
  const auto p = read_tum_trajectory(dir + "/t.txt");
  ASSERT_EQ(p.size(), 1u);
  EXPECT_LT((p[0].T_world_cam * Vec3(1, 0, 0) - Vec3(1, 3, 3)).norm(), 1e-6);
}

TEST(TumTrajectory, MalformedLinesNameFileAndLine) {
  const std::string dir = test::scratch_dir("m");
  std::ofstream(dir + "/bad.txt") << "# c\n0 0 0 0 0 0 0 1\n1 2 3\n";
  try {
    read_tum_trajectory(dir + "/bad.txt");
    FAIL();
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.txt"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("line 3"), std::string::npos);
  }
  std::ofstream(dir + "/nan.txt") << "0 nan 0 0 0 0 0 1\n";
  EXPECT_THROW(read_tum_trajectory(dir + "/nan.txt"), IoError);
  std::ofstream(dir + "/q.txt") << "0 0 0 0 0 0 0 0\n";
  EXPECT_THROW(read_tum_trajectory(dir + "/q.txt"), IoError);
  EXPECT_THROW(read_tum_trajectory(dir + "/missing.txt"), IoError);
}

// Issue 12: a FIFO named as a frame blocked the reader for ever.
TEST(ImageIo, AFrameThatIsNotARegularFileIsRefused) {
  const std::string dir = test::scratch_dir("fifo");
  const std::string fifo = dir + "/depth.png";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  try {
    read_depth_image(fifo, 1000.0);
    FAIL() << "read a FIFO";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("not a regular file"), std::string::npos) << e.what();
  }
}

TEST(BopResults, RoundTripInMillimetres) {
  const std::string dir = test::scratch_dir("b");
  PoseResultRow r;
  r.scene_id = 48;
  r.im_id = 12;
  r.obj_id = 5;
  r.score = 0.75;
  r.T_cam_obj = SE3(so3_exp(Vec3(0.1, 0.2, -0.3)), Vec3(0.1, -0.05, 0.8));
  r.time_s = 0.5;
  write_bop_results(dir + "/r.csv", {r, r});
  std::ifstream is(dir + "/r.csv");
  std::string header, first;
  std::getline(is, header);
  std::getline(is, first);
  EXPECT_EQ(header, "scene_id,im_id,obj_id,score,R,t,time");
  EXPECT_NE(first.find(",100.000000 -50.000000 800.000000,"), std::string::npos) << first;
  const auto rows = read_bop_results(dir + "/r.csv");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].scene_id, 48);
  EXPECT_EQ(rows[0].obj_id, 5);
  EXPECT_LT((rows[0].T_cam_obj.matrix() - r.T_cam_obj.matrix()).norm(), 1e-6);
}

TEST(BopResults, BadRowsAreErrors) {
  const std::string dir = test::scratch_dir("e");
  std::ofstream(dir + "/a.csv")
      << "scene_id,im_id,obj_id,score,R,t,time\n1,2,3,1,1 0 0 0 1 0 0 0 1,0 0\n";
  EXPECT_THROW(read_bop_results(dir + "/a.csv"), IoError);
  std::ofstream(dir + "/b.csv") << "1,2,3,1,1 0 0 0 1 0 0 0 2,0 0 0,-1\n";
  EXPECT_THROW(read_bop_results(dir + "/b.csv"), IoError);
}

// Integer fields were read by prefix (1.5 -> 1, 14abc -> 14, 1e+20 -> 1: rows on the wrong image)
// and a NaN score was accepted (issue 12).
TEST(BopResults, EveryFieldIsParsedWholeNamingLineAndField) {
  const std::string dir = test::scratch_dir("strict");
  const std::string rest = ",1 0 0 0 1 0 0 0 1,0 0 500,-1\n";
  const std::string header = "scene_id,im_id,obj_id,score,R,t,time\n";
  struct Case {
    std::string row, needle;
  };
  for (const Case& c :
       {Case{"1,1.5,3,0.9", "line 3, field im_id: '1.5' is not an integer"},
        Case{"1,14abc,3,0.9", "line 3, field im_id: '14abc'"},
        Case{"1,1e+20,3,0.9", "line 3, field im_id: '1e+20'"},
        Case{"99999999999,1,3,0.9", "line 3, field scene_id: '99999999999' is out of range"},
        Case{"1,-2,3,0.9", "line 3, field im_id: '-2' is out of range"},
        Case{"1,1,3x,0.9", "line 3, field obj_id"},
        Case{"1,1,3,nan", "line 3, field score: 'nan' is not a finite number"},
        Case{"1,1,3,0.9z", "line 3, field score"}}) {
    const std::string path = dir + "/r.csv";
    std::ofstream(path) << header << "1,1,3,0.5" << rest << c.row << rest;
    try {
      read_bop_results(path);
      ADD_FAILURE() << c.row << ": no error";
    } catch (const IoError& e) {
      EXPECT_NE(std::string(e.what()).find(c.needle), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  }
  std::ofstream(dir + "/ok.csv") << header << "1,1,3,0.5" << rest;
  EXPECT_EQ(read_bop_results(dir + "/ok.csv").size(), 1u);
}

TEST(ModelPoints, ReadsXyzAndRejectsGarbage) {
  const std::string dir = test::scratch_dir("x");
  std::ofstream(dir + "/p.xyz") << "0.1 0.2 0.3\n-1 0 1\n";
  const auto pts = read_xyz_points(dir + "/p.xyz");
  ASSERT_EQ(pts.size(), 2u);
  EXPECT_DOUBLE_EQ(pts[1].z(), 1.0);
  std::ofstream(dir + "/bad.xyz") << "0.1 0.2\n";
  EXPECT_THROW(read_xyz_points(dir + "/bad.xyz"), IoError);
  std::ofstream(dir + "/empty.xyz") << "";
  EXPECT_THROW(read_xyz_points(dir + "/empty.xyz"), IoError);
}

}  // namespace
}  // namespace orpe
