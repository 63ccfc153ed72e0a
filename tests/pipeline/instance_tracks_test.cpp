// hand_over_merged: per-instance state follows the semantic map's merges.
#include <gtest/gtest.h>

#include <map>
#include <string>

#include "orpe/pipeline/instance_tracks.h"

namespace orpe {
namespace {

struct FakeTrack {
  std::string name;
  int views = 0;
};

TEST(InstanceTracks, StateMovesToTheSurvivorAndTheHeavierOneWins) {
  // 5 was merged into 20, 24 into 20, 7 into 3 (chains resolved by the caller's resolve).
  const std::map<int, int> merged = {{5, 20}, {24, 20}, {7, 3}};
  auto resolve = [&](int id) {
    while (merged.count(id)) id = merged.at(id);
    return id;
  };
  auto views = [](const FakeTrack& t) { return t.views; };
  std::map<int, FakeTrack> tracks = {{1, {"untouched", 9}},
                                     {5, {"old", 50}},
                                     {20, {"new", 12}},
                                     {24, {"short", 5}},
                                     {7, {"only", 4}}};
  EXPECT_EQ(hand_over_merged(tracks, resolve, views), 3);
  ASSERT_EQ(tracks.size(), 3u);
  EXPECT_EQ(tracks.at(1).name, "untouched");
  EXPECT_EQ(tracks.at(20).name, "old") << "the track with more views survives the merge";
  EXPECT_EQ(tracks.at(20).views, 50);
  EXPECT_EQ(tracks.at(3).name, "only") << "a survivor without a track takes the absorbed one";
  EXPECT_EQ(tracks.count(5) + tracks.count(24) + tracks.count(7), 0u);
  // Nothing to do a second time.
  EXPECT_EQ(hand_over_merged(tracks, resolve, views), 0);
}

TEST(InstanceTracks, TieKeepsTheSurvivorsOwnState) {
  std::map<int, FakeTrack> tracks = {{2, {"absorbed", 3}}, {8, {"survivor", 3}}};
  hand_over_merged(
      tracks, [](int id) { return id == 2 ? 8 : id; }, [](const FakeTrack& t) { return t.views; });
  ASSERT_EQ(tracks.size(), 1u);
  EXPECT_EQ(tracks.at(8).name, "survivor");
}

}  // namespace
}  // namespace orpe
