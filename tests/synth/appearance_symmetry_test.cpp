// synth.symmetries=appearance (synth/appearance_symmetry.h): the symmetries written to
// models_info.json are those the print keeps too, so a box whose front and back labels differ is
// scored with ADD, not ADD-S; the scene itself does not change.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "orpe/render/mesh_io.h"
#include "orpe/render/primitives.h"
#include "orpe/synth/appearance_symmetry.h"
#include "orpe/synth/bop_writer.h"
#include "orpe/synth/generator.h"
#include "support/test_data.h"
#include "synth_test_util.h"

namespace orpe::test {
namespace {

using synth::appearance_symmetries;
using synth::make_builtin_object;

TEST(SynthAppearance, PrintedBoxesAndLabelledCansAreNotSymmetricFlatColoursAre) {
  for (const char* name : {"001_frasvaf_box", "003_jacky_box", "004_skansk_can", "009_tomatpure"}) {
    SCOPED_TRACE(name);
    const synth::ObjectModel m = make_builtin_object(name);
    ASSERT_TRUE(m.symmetries.any());  // the shape is symmetric
    const synth::ObjectSymmetries a = appearance_symmetries(m);
    EXPECT_TRUE(a.discrete.empty());
    EXPECT_TRUE(a.continuous.empty());
  }
  // The same box in one flat colour keeps every shape symmetry; one painted dark above 5 cm keeps
  // only the half turn about z (the flips about x and y put the dark band at the bottom).
  synth::ObjectModel flat = make_builtin_object("001_frasvaf_box");
  auto mesh = std::make_shared<TriangleMesh>(*flat.mesh);
  mesh->texture.reset();
  mesh->uvs.clear();
  mesh->base_color = {200, 40, 40};
  flat.mesh = mesh;
  const synth::ObjectSymmetries kept = appearance_symmetries(flat);
  EXPECT_EQ(kept.discrete.size(), flat.symmetries.discrete.size());

  synth::ObjectModel striped = flat;
  auto striped_mesh = std::make_shared<TriangleMesh>(*mesh);
  striped_mesh->colors.clear();
  for (const auto& v : striped_mesh->vertices) {
    const std::uint8_t g = v.z() > 0.05f ? 40 : 220;
    striped_mesh->colors.push_back({g, g, g});
  }
  striped_mesh->base_color = {255, 255, 255};
  striped.mesh = striped_mesh;
  const synth::ObjectSymmetries s = appearance_symmetries(striped);
  ASSERT_EQ(s.discrete.size(), 1u);
  EXPECT_GT(s.discrete[0].rotation()(2, 2), 0.99);

  // Two hues of one grey level (both 130.93 of 255) above and below 5 cm: the same in grey, not in
  // colour: only the half turn about z keeps it.
  synth::ObjectModel hued = flat;
  auto hued_mesh = std::make_shared<TriangleMesh>(*striped_mesh);
  for (size_t i = 0; i < hued_mesh->vertices.size(); ++i)
    hued_mesh->colors[i] = hued_mesh->vertices[i].z() > 0.05f ? Rgb8{180, 110, 110} : Rgb8{98, 144, 150};
  hued.mesh = hued_mesh;
  const synth::ObjectSymmetries h = appearance_symmetries(hued);
  ASSERT_EQ(h.discrete.size(), 1u);
  EXPECT_GT(h.discrete[0].rotation()(2, 2), 0.99);
}

std::string read_text(const std::string& path) {
  std::ifstream is(path, std::ios::binary);
  std::stringstream ss;
  ss << is.rdbuf();
  return ss.str();
}

TEST(SynthAppearance, OnlyModelsInfoDiffersFromTheShapeSetting) {
  SynthParams p = small_synth(3, 3, true);
  p.scene = "table";
  p.objects = 4;
  const std::string shape_dir = scratch_dir("appearance_shape"),
                    app_dir = scratch_dir("appearance");
  synth::SyntheticSceneGenerator(p).write_bop(shape_dir);
  p.symmetries = "appearance";
  synth::SyntheticSceneGenerator(p).write_bop(app_dir);
  for (const char* f :
       {"test/000000/scene_gt.json", "test/000000/rgb/000002.png", "test/000000/depth/000001.png",
        "models/obj_000001.ply", "models/obj_000001_points.xyz"})
    EXPECT_EQ(read_text(shape_dir + "/" + f), read_text(app_dir + "/" + f)) << f;
  const auto shape = read_json(shape_dir + "/models/models_info.json");
  const auto app = read_json(app_dir + "/models/models_info.json");
  int symmetric_shape = 0, symmetric_app = 0;
  for (const auto& [id, e] : shape.items()) symmetric_shape += e.contains("symmetries_discrete");
  for (const auto& [id, e] : app.items()) symmetric_app += e.contains("symmetries_discrete");
  EXPECT_EQ(symmetric_shape, 4);  // boxes and cans: all symmetric in shape
  EXPECT_EQ(symmetric_app, 0);    // none in appearance
  p.symmetries = "texture";
  std::string why;
  EXPECT_FALSE(p.IsValid(&why));
  EXPECT_NE(why.find("symmetries"), std::string::npos);
}

}  // namespace
}  // namespace orpe::test

namespace orpe::test {
namespace {

/// Grey-level correlation of mesh a's surface samples with mesh b's nearest samples.
double colour_correlation(const TriangleMesh& a, const TriangleMesh& b) {
  std::vector<Rgb8> ca, cb;
  const auto pa = sample_surface_points(a, 1500, 5, &ca);
  const auto pb = sample_surface_points(b, 6000, 6, &cb);
  double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
  for (size_t i = 0; i < pa.size(); ++i) {
    size_t best = 0;
    double bd = 1e9;
    for (size_t j = 0; j < pb.size(); ++j)
      if (const double d = (pa[i] - pb[j]).squaredNorm(); d < bd) bd = d, best = j;
    const double x = ca[i].r + ca[i].g + ca[i].b, y = cb[best].r + cb[best].g + cb[best].b;
    sx += x, sy += y, sxx += x * x, syy += y * y, sxy += x * y;
  }
  const double n = static_cast<double>(pa.size());
  return (sxy / n - sx / n * sy / n) /
         std::sqrt((sxx / n - sx / n * sx / n) * (syy / n - sy / n * sy / n));
}

TEST(SynthAppearance, WrittenModelsCarryTheirPrintTheRightWayRound) {
  // The pose stage ranks poses by the colour of the model it reads back (PLY + PNG): it must be
  // the print the images show, not a mirrored or flipped one.
  for (const char* name : {"006_onos_can", "003_jacky_box", "001_frasvaf_box"}) {
    SCOPED_TRACE(name);
    const synth::ObjectModel m = make_builtin_object(name);
    const std::string dir = scratch_dir(std::string("written_model_") + name);
    synth::write_bop_models(dir, {m}, 200, 1);
    MeshLoadOptions opt;
    opt.metres_per_unit = 0.001;
    const TriangleMesh back = load_mesh(dir + "/obj_000001.ply", opt);
    ASSERT_TRUE(back.has_texture() || back.has_colors());
    // Nearest samples differ by the sampling: the mesh against itself (other samples) is the bar.
    const double self = colour_correlation(*m.mesh, *m.mesh);
    const double written = colour_correlation(*m.mesh, back);
    std::printf("%s self %.3f written %.3f\n", name, self, written);
    EXPECT_GT(written, 0.9 * self);
  }
}

}  // namespace
}  // namespace orpe::test
