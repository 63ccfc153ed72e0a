// OUT/frames.csv (pipeline/frame_log.h): written and read back; a malformed line names file and
// line.
#include <gtest/gtest.h>

#include <fstream>

#include "orpe/core/error.h"
#include "orpe/pipeline/frame_log.h"
#include "support/test_data.h"

namespace orpe {
namespace {

TEST(FrameLog, RecordsRoundTripThroughTheCsv) {
  FrameLog log;
  PipelineFrameResult r;
  r.frame_index = 7;
  r.timestamp_s = 0.25;
  r.slam.status = slam::TrackingStatus::kDegraded;
  r.keyframe = true;
  r.detections = 3;
  r.instances = 2;
  r.slam_ms = 12.5;
  r.total_ms = 40;
  log.add(r, 4.5, 1000, 3 * 1048576);
  const std::string path = test::scratch_dir("log") + "/frames.csv";
  log.write(path);
  const auto back = read_frame_log(path);
  ASSERT_EQ(back.size(), 1u);
  EXPECT_EQ(back[0].frame, 7);
  EXPECT_EQ(back[0].status, "DEGRADED");
  EXPECT_TRUE(back[0].keyframe);
  EXPECT_FALSE(back[0].evaluated);
  EXPECT_EQ(back[0].surfels, 1000u);
  EXPECT_DOUBLE_EQ(back[0].map_mb, 3.0);
  EXPECT_DOUBLE_EQ(back[0].read_ms, 4.5);
  EXPECT_DOUBLE_EQ(back[0].slam_ms, 12.5);
  EXPECT_GT(back[0].rss_mb, 1.0) << "this process's resident memory";
}

TEST(FrameLog, AMalformedLineIsAnErrorNamingFileAndLine) {
  const std::string path = test::scratch_dir("bad") + "/frames.csv";
  FrameLog log;
  log.add(PipelineFrameResult{}, 0, 0, 0);
  log.write(path);
  std::ofstream(path, std::ios::app) << "1,0,WOBBLY,0,0,0,0,0,0,0,0,0,0,0,0,0,0\n";
  try {
    read_frame_log(path);
    FAIL() << "accepted a bad status";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("line 3"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace orpe
