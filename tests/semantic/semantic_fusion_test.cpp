#include <gtest/gtest.h>

#include <map>
#include <set>

#include "orpe/core/error.h"
#include "orpe/semantic/semantic_fusion.h"
#include "semantic/planar_setup.h"

namespace orpe {
namespace {

MaskImage rect_mask(int w, int h, int u0, int v0, int u1, int v1) {
  MaskImage m(w, h, 0);
  for (int v = std::max(0, v0); v <= std::min(h - 1, v1); ++v)
    for (int u = std::max(0, u0); u <= std::min(w - 1, u1); ++u) m.at(u, v) = 1;
  return m;
}

void paint(LabelImage& img, int id, int u0, int v0, int u1, int v1) {
  for (int v = v0; v <= v1; ++v)
    for (int u = u0; u <= u1; ++u) img.at(u, v) = id;
}

// ---------------------------------------------------------------- association
TEST(Association, LargestOverlapAboveThresholdElseNew) {
  LabelImage rendered(60, 40, 0);
  paint(rendered, 5, 0, 0, 9, 9);    // 100 px
  paint(rendered, 8, 30, 0, 49, 9);  // 200 px
  // Covers 60 % of instance 5 and 10 % of instance 8.
  const auto a = associate_detections(
      {rect_mask(60, 40, 4, 0, 31, 9), rect_mask(60, 40, 0, 20, 20, 30)}, rendered, 0.3, 1);
  EXPECT_EQ(a[0].instance_id, 5);
  EXPECT_NEAR(a[0].overlap, 0.6, 1e-9);
  EXPECT_EQ(a[1].instance_id, 0);  // no overlap: new instance
  // U exactly at the threshold is not enough (paper: U > 0.3).
  const auto b = associate_detections({rect_mask(60, 40, 0, 0, 2, 9)}, rendered, 0.3, 1);
  EXPECT_EQ(b[0].instance_id, 0);
  EXPECT_NEAR(b[0].overlap, 0.3, 1e-9);
}

TEST(Association, TiesGoToLargerIntersectionThenLowerId) {
  LabelImage rendered(60, 40, 0);
  paint(rendered, 7, 0, 0, 9, 9);    // 100 px
  paint(rendered, 3, 20, 0, 39, 9);  // 200 px
  // Half of each: U = 0.5 for both; instance 3's intersection (100) beats 7's (50).
  auto a = associate_detections({rect_mask(60, 40, 5, 0, 29, 9)}, rendered, 0.3, 1);
  EXPECT_EQ(a[0].instance_id, 3);
  EXPECT_EQ(a[0].also_overlapping, std::vector<int>{7});
  // Equal U and equal intersection: the lower id wins.
  LabelImage same(60, 40, 0);
  paint(same, 9, 0, 0, 9, 9);
  paint(same, 4, 20, 0, 29, 9);
  a = associate_detections({rect_mask(60, 40, 0, 0, 29, 9)}, same, 0.3, 1);
  EXPECT_EQ(a[0].instance_id, 4);
  EXPECT_EQ(a[0].also_overlapping, std::vector<int>{9});
}

TEST(Association, TinyProjectionsCannotCaptureALargeDetection) {
  LabelImage rendered(60, 40, 0);
  paint(rendered, 2, 0, 0, 1, 1);                         // 4 stray pixels
  paint(rendered, 6, 10, 10, 29, 29);                     // 400 px
  const MaskImage big = rect_mask(60, 40, 0, 0, 25, 25);  // all of 2, 64 % of 6
  EXPECT_EQ(associate_detections({big}, rendered, 0.3, 1)[0].instance_id,
            2);  // the paper's raw rule
  EXPECT_EQ(associate_detections({big}, rendered, 0.3, 50)[0].instance_id, 6);  // with the floor
  // A tiny detection on a big instance: U = 4 / 400, a new instance.
  EXPECT_EQ(
      associate_detections({rect_mask(60, 40, 12, 12, 13, 13)}, rendered, 0.3, 50)[0].instance_id,
      0);
  // An empty mask never matches.
  EXPECT_EQ(associate_detections({MaskImage(60, 40, 0)}, rendered, 0.3, 50)[0].instance_id, 0);
}

TEST(Association, MasksAtTheImageBorder) {
  LabelImage rendered(60, 40, 0);
  paint(rendered, 1, 50, 30, 59, 39);  // bottom-right corner, 100 px
  // The detection is cut by the border: only the in-image part counts.
  EXPECT_EQ(
      associate_detections({rect_mask(60, 40, 54, 34, 70, 50)}, rendered, 0.3, 1)[0].instance_id,
      1);
  EXPECT_NEAR(
      associate_detections({rect_mask(60, 40, 54, 34, 70, 50)}, rendered, 0.3, 1)[0].overlap, 0.36,
      1e-9);
  EXPECT_THROW(associate_detections({MaskImage(30, 40, 0)}, rendered, 0.3, 1), ConfigError);
}

// ---------------------------------------------------------------- neighbourhood
TEST(ObjectNeighbourhood, ChebyshevRadiusAndNearestLabel) {
  LabelImage labels(40, 30, 0);
  labels.at(10, 10) = 4;
  labels.at(20, 10) = 9;
  const ObjectNeighbourhood nb(labels, 6);
  EXPECT_TRUE(nb.has_object_pixel(16, 16));   // Chebyshev distance 6 (diagonal)
  EXPECT_FALSE(nb.has_object_pixel(10, 17));  // 7 rows away
  EXPECT_FALSE(nb.has_object_pixel(3, 3));    // 7 away diagonally
  EXPECT_TRUE(nb.has_object_pixel(4, 10));
  EXPECT_EQ(nb.nearest_label(14, 10), 4);
  EXPECT_EQ(nb.nearest_label(16, 10), 9);
  EXPECT_EQ(nb.nearest_label(10, 25), 0);
  // At the image border the window is clipped, not wrapped.
  LabelImage corner(40, 30, 0);
  corner.at(0, 0) = 2;
  const ObjectNeighbourhood nc(corner, 6);
  EXPECT_TRUE(nc.has_object_pixel(0, 6));
  EXPECT_FALSE(nc.has_object_pixel(39, 0));
  EXPECT_EQ(nc.nearest_label(3, 2), 2);
}

// ---------------------------------------------------------------- fusion rules
SemanticParams no_pruning() {
  SemanticParams p;
  p.min_instance_detections = 1;
  p.min_visible_area_px = 1;
  p.min_instance_surfels = 0;
  p.min_detection_ratio = 0;
  return p;
}

TEST(SemanticFusion, ClassProbabilityIsTheAverageOverDetectingFrames) {
  test::PlanarSetup s;
  SemanticFusion fusion(no_pruning());
  const int W = s.K.width, H = s.K.height;
  const std::vector<std::vector<std::pair<int, float>>> per_frame = {
      {{3, 0.9f}}, {{3, 0.8f}}, {{5, 0.7f}}, {{3, 0.6f}, {5, 0.3f}}};
  for (size_t f = 0; f < per_frame.size(); ++f) {
    Detection d = test::rect_detection(W, H, per_frame[f].front().first, 0.9f, 10, 10, 30, 30);
    d.class_probabilities = per_frame[f];
    fusion.integrate(s.frame(static_cast<int>(f)), {d}, SE3(), s.map, &s.pixel_surfel);
    // A frame without detections does not count towards the average.
    fusion.integrate(s.frame(100 + static_cast<int>(f)), {}, SE3(), s.map, &s.pixel_surfel);
  }
  ASSERT_EQ(fusion.instances().size(), 1u);
  const InstanceInfo& info = fusion.instances().begin()->second;
  EXPECT_EQ(info.detections, 4);
  const auto dist = info.class_distribution();
  ASSERT_EQ(dist.size(), 2u);
  EXPECT_EQ(dist[0].first, 3);
  EXPECT_NEAR(dist[0].second, (0.9 + 0.8 + 0.6) / 4, 1e-6);
  EXPECT_EQ(dist[1].first, 5);
  EXPECT_NEAR(dist[1].second, (0.7 + 0.3) / 4, 1e-6);
  EXPECT_EQ(info.argmax_class(), 3);
  EXPECT_EQ(info.first_frame, 0);
  EXPECT_EQ(info.last_frame, 3);
}

TEST(SemanticFusion, SurfelsTakeTheInstanceAndAverageTheirProbability) {
  test::PlanarSetup s;
  SemanticFusion fusion(no_pruning());
  const int W = s.K.width, H = s.K.height;
  const auto rep = fusion.integrate(
      s.frame(0), {test::rect_detection(W, H, 2, 0.9f, 10, 10, 19, 19, 0.9f, 0.1f)}, SE3(), s.map,
      &s.pixel_surfel);
  EXPECT_EQ(rep.new_instances, 1);
  EXPECT_EQ(rep.surfels_labelled, 100);
  EXPECT_EQ(rep.surfels_observed, W * H);
  const int id = fusion.instances().begin()->first;
  EXPECT_EQ(s.map.instance_id[s.surfel(15, 15)], id);
  EXPECT_EQ(s.map.always_active[s.surfel(15, 15)], 1);
  EXPECT_EQ(s.map.instance_id[s.surfel(25, 15)], 0);
  EXPECT_EQ(s.map.always_active[s.surfel(25, 15)], 0);
  // Second frame shifted by 2 px: associates (U = 0.8), p_o averages.
  const auto rep2 = fusion.integrate(
      s.frame(1), {test::rect_detection(W, H, 2, 0.9f, 12, 10, 21, 19, 0.8f, 0.1f)}, SE3(), s.map,
      &s.pixel_surfel);
  EXPECT_EQ(rep2.associated, 1);
  EXPECT_EQ(rep2.new_instances, 0);
  EXPECT_EQ(fusion.instances().size(), 1u);
  EXPECT_NEAR(s.map.p_object[s.surfel(15, 15)], (0.9 + 0.8) / 2, 1e-6);
  EXPECT_NEAR(s.map.p_object[s.surfel(11, 15)], (0.9 + 0.1) / 2, 1e-6);
  EXPECT_EQ(s.map.object_obs_count[s.surfel(11, 15)], 2);
  EXPECT_EQ(s.map.instance_id[s.surfel(21, 15)], id);  // newly covered, p_o 0.45 > 0.4: joins
  EXPECT_EQ(s.map.instance_id[s.surfel(11, 15)], id);  // p_o 0.5 > 0.4: kept
  // A third frame of background there: p_o = 1.1 / 3 <= 0.4 -> released.
  fusion.integrate(s.frame(2), {test::rect_detection(W, H, 2, 0.9f, 12, 10, 21, 19, 0.7f, 0.1f)},
                   SE3(), s.map, &s.pixel_surfel);
  EXPECT_EQ(s.map.instance_id[s.surfel(11, 15)], 0);
  EXPECT_EQ(s.map.always_active[s.surfel(11, 15)], 0);
  EXPECT_EQ(s.map.instance_id[s.surfel(15, 15)], id);
}

TEST(SemanticFusion, IndexMapPathMatchesThePixelSurfelPath) {
  test::PlanarSetup a, b;
  SemanticFusion fa(no_pruning()), fb(no_pruning());
  const int W = a.K.width, H = a.K.height;
  const auto det = test::rect_detection(W, H, 2, 0.9f, 10, 10, 29, 24, 0.8f, 0.2f);
  fa.integrate(a.frame(0), {det}, SE3(), a.map, &a.pixel_surfel);
  const auto rep = fb.integrate(b.frame(0), {det}, SE3(), b.map);
  EXPECT_EQ(rep.surfels_observed, W * H);
  EXPECT_EQ(a.map.instance_id, b.map.instance_id);
  EXPECT_EQ(a.map.p_object, b.map.p_object);
  // Surfels off the measured depth are not observed.
  RgbdFrame far = b.frame(1);
  far.depth.fill(1.5f);
  EXPECT_EQ(fb.integrate(far, {det}, SE3(), b.map).surfels_observed, 0);
}

// Boundary band: object core u <= 29 (p = 0.9); u in [30, 33] p = band_p(frame); u >= 40 p = 0.45
// but more than 6 px from any object pixel; elsewhere 0.05.
Detection band_detection(int W, int H, float band_p) {
  return test::make_detection(W, H, 4, 0.9f, [=](int u, int v) -> float {
    if (v < 10 || v > 40) return 0.05f;
    if (u >= 10 && u <= 29) return 0.9f;
    if (u >= 30 && u <= 33) return band_p;
    if (u >= 40 && u <= 45) return 0.45f;
    return 0.05f;
  });
}

TEST(SemanticFusion, BoundarySurfelsJoinAfterNSupportingFrames) {
  test::PlanarSetup s;
  SemanticFusion fusion(no_pruning());
  const int W = s.K.width, H = s.K.height;
  const auto band = s.surfel(32, 20), far = s.surfel(42, 20);
  int joined = 0;
  for (int f = 0; f < 10; ++f) {
    const auto rep =
        fusion.integrate(s.frame(f), {band_detection(W, H, 0.45f)}, SE3(), s.map, &s.pixel_surfel);
    joined += rep.boundary_joined;
    if (f < 9) {
      EXPECT_EQ(s.map.instance_id[band], 0) << f;
      EXPECT_EQ(s.map.boundary_counter[band] & 0x0f, f + 1);  // criteria (i) and (ii) hold
      EXPECT_EQ(s.map.boundary_counter[band] >> 4, f + 1);
      EXPECT_EQ(s.map.boundary_counter[far] & 0x0f, 0);  // (ii) fails: no object pixel within 6
    }
  }
  const int id = fusion.instances().begin()->first;
  EXPECT_EQ(s.map.instance_id[band], id);
  EXPECT_EQ(s.map.always_active[band], 1);
  EXPECT_EQ(s.map.instance_id[far], 0);
  EXPECT_EQ(s.map.boundary_counter[far], 0);  // window ended: reset
  EXPECT_EQ(joined, 4 * 31);                  // the 4-column band, rows 10..40
}

TEST(SemanticFusion, BoundaryCounterResetsWhenAFrameFailsCriterionOne) {
  test::PlanarSetup s;
  SemanticFusion fusion(no_pruning());
  const int W = s.K.width, H = s.K.height;
  const auto band = s.surfel(32, 20);
  // Frame 4 gives the band 0.39 (<= 0.4): p_o stays in (0.4, 0.5) but the frame does not count.
  for (int f = 0; f < 10; ++f)
    fusion.integrate(s.frame(f), {band_detection(W, H, f == 4 ? 0.39f : 0.47f)}, SE3(), s.map,
                     &s.pixel_surfel);
  EXPECT_GT(s.map.p_object[band], 0.4f);
  EXPECT_LT(s.map.p_object[band], 0.5f);
  EXPECT_EQ(s.map.instance_id[band], 0);
  EXPECT_EQ(s.map.boundary_counter[band], 0);  // 9 < sigma = 10 after n = 10 frames: reset
  for (int f = 10; f < 20; ++f)
    fusion.integrate(s.frame(f), {band_detection(W, H, 0.47f)}, SE3(), s.map, &s.pixel_surfel);
  EXPECT_EQ(s.map.instance_id[band], fusion.instances().begin()->first);
}

TEST(SemanticFusion, SpuriousInstancesArePrunedAndFinalizeRemovesRareOnes) {
  test::PlanarSetup s;
  SemanticParams p;
  p.release_probability =
      0;  // keep the blob's surfels labelled: pruning, not release, must remove it
  p.min_instance_detections = 3;
  p.prune_missed_keyframes = 5;
  p.min_instance_surfels = 10;
  SemanticFusion fusion(p);
  const int W = s.K.width, H = s.K.height;
  const auto object = test::rect_detection(W, H, 1, 0.95f, 5, 5, 24, 24);
  const auto blob = test::rect_detection(W, H, 7, 0.6f, 50, 30, 59, 39);
  fusion.integrate(s.frame(0), {object, blob}, SE3(), s.map, &s.pixel_surfel);
  ASSERT_EQ(fusion.instances().size(), 2u);
  int pruned_at = -1;
  for (int f = 1; f <= 6; ++f) {
    const auto rep = fusion.integrate(s.frame(f), {object}, SE3(), s.map, &s.pixel_surfel);
    if (rep.pruned_instances && pruned_at < 0) pruned_at = f;
  }
  EXPECT_EQ(pruned_at, 5);  // visible but undetected in frames 1..5
  ASSERT_EQ(fusion.instances().size(), 1u);
  EXPECT_EQ(fusion.instances().begin()->second.argmax_class(), 1);
  EXPECT_EQ(s.map.instance_id[s.surfel(55, 35)], 0);
  // A blob seen twice and then never again (out of view) survives the run but not finalize().
  const auto blob2 = test::rect_detection(W, H, 7, 0.6f, 50, 30, 59, 39);
  fusion.integrate(s.frame(7), {object, blob2}, SE3(), s.map, &s.pixel_surfel);
  fusion.integrate(s.frame(8), {object, blob2}, SE3(), s.map, &s.pixel_surfel);
  EXPECT_EQ(fusion.instances().size(), 2u);
  EXPECT_EQ(fusion.finalize(s.map), 1);
  ASSERT_EQ(fusion.instances().size(), 1u);
  EXPECT_EQ(fusion.instances().begin()->second.argmax_class(), 1);
  EXPECT_EQ(s.map.instance_id[s.surfel(55, 35)], 0);
  EXPECT_GT(s.map.instance_id[s.surfel(10, 10)], 0);
}

TEST(SemanticFusion, FinalizeRemovesInstancesDetectedInTooFewOfTheirChances) {
  for (const double ratio : {0.5, 0.0}) {
    test::PlanarSetup s;
    SemanticParams p;
    p.min_detection_ratio = ratio;
    SemanticFusion fusion(p);
    const int W = s.K.width, H = s.K.height;
    const auto object = test::rect_detection(W, H, 1, 0.95f, 5, 5, 24, 24);
    const auto flicker = test::rect_detection(W, H, 7, 0.6f, 50, 30, 59, 39);
    const auto steady = test::rect_detection(W, H, 4, 0.7f, 50, 5, 59, 14);
    // flicker: detected in keyframes 0-2, visible and undetected in 3-9 (3 of 10 chances);
    // steady: detected in 0, 2, 4, 6, 8, missed in 1, 3, 5, 7, 9 (5 of 10).
    for (int f = 0; f < 10; ++f) {
      std::vector<Detection> d = {object};
      if (f < 3) d.push_back(flicker);
      if (f % 2 == 0) d.push_back(steady);
      fusion.integrate(s.frame(f), d, SE3(), s.map, &s.pixel_surfel);
    }
    ASSERT_EQ(fusion.instances().size(), 3u) << "detected 3 times: not pruned during the run";
    std::map<int, const InstanceInfo*> by_class;
    for (const auto& [id, info] : fusion.instances()) by_class[info.argmax_class()] = &info;
    EXPECT_EQ(by_class.at(7)->detections, 3);
    EXPECT_EQ(by_class.at(7)->missed_keyframes, 7);
    EXPECT_NEAR(by_class.at(7)->detection_ratio(), 0.3, 1e-12);
    EXPECT_NEAR(by_class.at(4)->detection_ratio(), 0.5, 1e-12);
    EXPECT_NEAR(by_class.at(1)->detection_ratio(), 1.0, 1e-12);
    fusion.finalize(s.map);
    std::set<int> classes;
    for (const auto& [id, info] : fusion.instances()) classes.insert(info.argmax_class());
    if (ratio > 0) {
      EXPECT_EQ(classes, (std::set<int>{1, 4}));
      EXPECT_EQ(s.map.instance_id[s.surfel(55, 35)], 0) << "its surfels are unlabelled";
    } else {
      EXPECT_EQ(classes, (std::set<int>{1, 4, 7})) << "rule off: the flicker survives";
    }
  }
}

TEST(SemanticFusion, FinalizeRemovesInstancesTooLowAboveTheSupportForTheirClass) {
  for (const double fraction : {0.7, 0.0}) {
    test::PlanarSetup s;  // the wall of surfels is the support plane (1 x 0.75 m)
    SemanticParams p = no_pruning();
    p.min_height_fraction = fraction;
    SemanticFusion fusion(p);
    const int W = s.K.width, H = s.K.height;
    const auto sheet = test::rect_detection(W, H, 2, 0.9f, 5, 5, 19, 19);  // flat on the wall
    const auto box = test::rect_detection(W, H, 3, 0.9f, 40, 30, 54, 44);  // stands off it
    const auto tall = test::rect_detection(W, H, 4, 0.9f, 60, 5, 74, 19);  // class without width
    for (int f = 0; f < 3; ++f)
      fusion.integrate(s.frame(f), {sheet, box, tall}, SE3(), s.map, &s.pixel_surfel);
    ASSERT_EQ(fusion.instances().size(), 3u);
    // The box's surfels 6 cm in front of the wall (towards the camera).
    for (int v = 30; v <= 44; ++v)
      for (int u = 40; u <= 54; ++u) s.map.position_world[s.surfel(u, v)].z() -= 0.06f;
    fusion.set_class_min_widths({{2, 0.05}, {3, 0.05}});
    fusion.finalize(s.map);
    std::set<int> classes;
    for (const auto& [id, info] : fusion.instances()) {
      classes.insert(info.argmax_class());
      if (info.argmax_class() == 3) {
        EXPECT_NEAR(info.height_above_support_m, 0.06, 0.002);
      } else if (info.argmax_class() == 2) {
        EXPECT_LT(info.height_above_support_m, 0.003);
      }
    }
    if (fraction > 0)
      EXPECT_EQ(classes, (std::set<int>{3, 4})) << "the sheet is no object of 5 cm";
    else
      EXPECT_EQ(classes, (std::set<int>{2, 3, 4})) << "rule off";
  }
}

TEST(SemanticFusion, InstancesWhoseSurfelsWereAllReleasedAreRemoved) {
  test::PlanarSetup s;
  SemanticParams p;
  p.skip_missed_instances = false;  // let the undetected blob's surfels fall to background
  SemanticFusion fusion(p);
  const int W = s.K.width, H = s.K.height;
  const auto object = test::rect_detection(W, H, 1, 0.95f, 5, 5, 24, 24);
  fusion.integrate(s.frame(0), {object, test::rect_detection(W, H, 7, 0.6f, 50, 30, 59, 39)}, SE3(),
                   s.map, &s.pixel_surfel);
  ASSERT_EQ(fusion.instances().size(), 2u);
  fusion.integrate(s.frame(1), {object}, SE3(), s.map, &s.pixel_surfel);  // blob p_o 0.475: kept
  EXPECT_EQ(fusion.instances().size(), 2u);
  const auto rep =
      fusion.integrate(s.frame(2), {object}, SE3(), s.map, &s.pixel_surfel);  // 0.33: released
  EXPECT_EQ(rep.surfels_released, 100);
  EXPECT_EQ(rep.pruned_instances, 1);
  ASSERT_EQ(fusion.instances().size(), 1u);
  EXPECT_EQ(fusion.instances().begin()->second.argmax_class(), 1);
}

TEST(SemanticFusion, AMissedDetectionDoesNotPullSurfelsTowardsBackground) {
  for (bool skip : {true, false}) {
    test::PlanarSetup s;
    SemanticParams p = no_pruning();
    p.skip_missed_instances = skip;
    SemanticFusion fusion(p);
    const int W = s.K.width, H = s.K.height;
    const auto object = test::rect_detection(W, H, 1, 0.95f, 10, 10, 29, 29, 0.6f, 0.0f);
    fusion.integrate(s.frame(0), {object}, SE3(), s.map, &s.pixel_surfel);
    // A tentative instance (one detection) does not protect its surfels...
    RgbdFrame elsewhere = s.frame(1);
    elsewhere.depth.fill(3.0f);  // ...(this frame observes no surfel, so nothing changes)
    EXPECT_EQ(fusion.integrate(elsewhere, {}, SE3(), s.map).missed_instances, 0);
    // Confirmed by a second detection, then missed.
    fusion.integrate(s.frame(2), {object}, SE3(), s.map, &s.pixel_surfel);
    const auto rep = fusion.integrate(s.frame(3), {}, SE3(), s.map, &s.pixel_surfel);
    EXPECT_EQ(rep.missed_instances, 1);
    const auto inside = s.surfel(20, 20), near = s.surfel(33, 20), far = s.surfel(60, 50);
    if (skip) {
      EXPECT_NEAR(s.map.p_object[inside], 0.6f, 1e-6);
      EXPECT_EQ(s.map.object_obs_count[inside], 2);
      EXPECT_EQ(s.map.object_obs_count[near], 2);  // within 6 px of the projection: skipped too
      EXPECT_EQ(rep.surfels_skipped,
                32 * 32);  // the 20x20 projection dilated by 6 px (square window)
      EXPECT_EQ(s.map.instance_id[inside], fusion.instances().begin()->first);
    } else {
      EXPECT_NEAR(s.map.p_object[inside], 0.4f, 1e-6);
      EXPECT_EQ(s.map.instance_id[inside], 0);  // released: p_o 0.4 <= 0.4
    }
    EXPECT_EQ(s.map.object_obs_count[far], 3);
  }
}

TEST(SemanticFusion, SameClassInstancesOverlappedByOneDetectionMerge) {
  test::PlanarSetup s;
  SemanticFusion fusion(no_pruning());
  const int W = s.K.width, H = s.K.height;
  // Two halves of one object detected as two instances (both class 3), then one detection over
  // both.
  fusion.integrate(s.frame(0),
                   {test::rect_detection(W, H, 3, 0.9f, 10, 10, 19, 29),
                    test::rect_detection(W, H, 3, 0.8f, 20, 10, 29, 29)},
                   SE3(), s.map, &s.pixel_surfel);
  ASSERT_EQ(fusion.instances().size(), 2u);
  const auto rep =
      fusion.integrate(s.frame(1), {test::rect_detection(W, H, 3, 0.9f, 10, 10, 29, 29)}, SE3(),
                       s.map, &s.pixel_surfel);
  EXPECT_EQ(rep.merged_instances, 1);
  ASSERT_EQ(fusion.instances().size(), 1u);
  const int id = fusion.instances().begin()->first;
  EXPECT_EQ(s.map.instance_id[s.surfel(12, 12)], id);
  EXPECT_EQ(s.map.instance_id[s.surfel(27, 27)], id);
  EXPECT_EQ(fusion.instances().begin()->second.detections, 3);
  // The absorbed id is on record and resolves to the survivor (later stages hand over its state).
  ASSERT_EQ(fusion.merged_into().size(), 1u);
  const int absorbed = fusion.merged_into().begin()->first;
  EXPECT_NE(absorbed, id);
  EXPECT_EQ(fusion.merged_into().begin()->second, id);
  EXPECT_EQ(fusion.resolve_instance(absorbed), id);
  EXPECT_EQ(fusion.resolve_instance(id), id);
  EXPECT_EQ(fusion.resolve_instance(12345), 12345) << "unknown ids resolve to themselves";
  // Different classes never merge.
  test::PlanarSetup t;
  SemanticFusion other(no_pruning());
  other.integrate(t.frame(0),
                  {test::rect_detection(W, H, 3, 0.9f, 10, 10, 19, 29),
                   test::rect_detection(W, H, 4, 0.8f, 20, 10, 29, 29)},
                  SE3(), t.map, &t.pixel_surfel);
  other.integrate(t.frame(1), {test::rect_detection(W, H, 3, 0.9f, 10, 10, 29, 29)}, SE3(), t.map,
                  &t.pixel_surfel);
  EXPECT_EQ(other.instances().size(), 2u);
}

TEST(SemanticFusion, FirstComeOwnershipBetweenOverlappingDetections) {
  test::PlanarSetup s;
  SemanticFusion fusion(no_pruning());
  const int W = s.K.width, H = s.K.height;
  // Overlap columns 20..24: the higher probability wins the pixel in the first frame.
  fusion.integrate(s.frame(0),
                   {test::rect_detection(W, H, 1, 0.9f, 5, 10, 24, 29, 0.95f),
                    test::rect_detection(W, H, 2, 0.8f, 20, 10, 40, 29, 0.7f)},
                   SE3(), s.map, &s.pixel_surfel);
  const int a = s.map.instance_id[s.surfel(10, 15)], b = s.map.instance_id[s.surfel(35, 15)];
  ASSERT_NE(a, b);
  EXPECT_EQ(s.map.instance_id[s.surfel(22, 15)], a);
  // Later, the other detection is more confident there: the surfel keeps its owner.
  fusion.integrate(s.frame(1),
                   {test::rect_detection(W, H, 1, 0.9f, 5, 10, 24, 29, 0.6f),
                    test::rect_detection(W, H, 2, 0.8f, 20, 10, 40, 29, 0.99f)},
                   SE3(), s.map, &s.pixel_surfel);
  EXPECT_EQ(s.map.instance_id[s.surfel(22, 15)], a);
}

TEST(SemanticFusion, BadInputsAreErrors) {
  test::PlanarSetup s;
  SemanticFusion fusion(no_pruning());
  EXPECT_THROW(fusion.integrate(s.frame(0), {test::rect_detection(10, 10, 1, 0.9f, 0, 0, 5, 5)},
                                SE3(), s.map),
               IoError);
  RgbdFrame no_depth = s.frame(0);
  no_depth.depth = DepthImage();
  EXPECT_THROW(fusion.integrate(no_depth, {}, SE3(), s.map), IoError);
  slam::IndexImage wrong(3, 3, -1);
  EXPECT_THROW(fusion.integrate(s.frame(0), {}, SE3(), s.map, &wrong), ConfigError);
  // ... refused before anything changed: no instance made from the frame's detection.
  const int W = s.K.width, H = s.K.height;
  EXPECT_THROW(fusion.integrate(s.frame(0), {test::rect_detection(W, H, 2, 0.9f, 10, 10, 19, 19)},
                                SE3(), s.map, &wrong),
               ConfigError);
  EXPECT_TRUE(fusion.instances().empty());
  SemanticParams p;
  p.boundary_window_frames = 16;
  EXPECT_THROW(SemanticFusion{p}, ConfigError);
  p = {};
  p.boundary_min_count = 11;
  std::string why;
  EXPECT_FALSE(p.IsValid(&why));
}

}  // namespace
}  // namespace orpe
