#include "orpe/render/mesh_io.h"

#include <gtest/gtest.h>

#include <cstring>
#include <fstream>

#include "orpe/core/error.h"
#include "orpe/io/image_io.h"
#include "orpe/render/primitives.h"
#include "support/test_data.h"

namespace orpe {
namespace {

void write_text(const std::string& path, const std::string& text) {
  std::ofstream os(path, std::ios::binary);
  os << text;
}

/// Expects `f` to throw IoError whose message names `path`; returns the message.
template <class F>
std::string expect_io_error(const std::string& path, F&& f) {
  try {
    f();
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_EQ(e.path(), path);
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "expected IoError, got " << e.what();
    return {};
  }
  ADD_FAILURE() << "expected IoError for " << path;
  return {};
}

const char* kCubeObj = R"(# a unit cube in millimetres, quads, with uvs, normals and a material
mtllib cube.mtl
v -500 -500 -500
v 500 -500 -500
v 500 500 -500
v -500 500 -500
v -500 -500 500
v 500 -500 500
v 500 500 500
v -500 500 500
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vn 0 0 -1
vn 0 0 1
vn 0 -1 0
vn 1 0 0
vn 0 1 0
vn -1 0 0
usemtl boxmat
f 1/1/1 4/4/1 3/3/1 2/2/1
f 5/1/2 6/2/2 7/3/2 8/4/2
f 1/1/3 2/2/3 6/3/3 5/4/3
f 2/1/4 3/2/4 7/3/4 6/4/4
f 3/1/5 4/2/5 8/3/5 7/4/5
f -4/1/6 -8/2/6 -5/3/6 -1/4/6
)";

TEST(MeshIo, ObjWithMaterialTextureAndUnitScale) {
  const std::string dir = test::scratch_dir("obj");
  write_text(dir + "/cube.obj", kCubeObj);
  write_text(dir + "/cube.mtl", "newmtl boxmat\nKd 0.5 0.5 0.5\nmap_Kd tex.png\n");
  ColorImage tex(8, 4, Rgb8{10, 200, 30});
  write_color_png(dir + "/tex.png", tex);
  MeshLoadOptions opt;
  opt.metres_per_unit = 0.001;
  const TriangleMesh m = load_mesh(dir + "/cube.obj", opt);
  EXPECT_EQ(m.num_triangles(), 12u);
  EXPECT_EQ(m.num_vertices(), 24u);  // 6 faces x 4 corners with distinct (v, vt, vn)
  const auto box = m.bounds();
  EXPECT_NEAR(box.min().x(), -0.5, 1e-6);
  EXPECT_NEAR(box.max().z(), 0.5, 1e-6);
  ASSERT_TRUE(m.has_texture());
  EXPECT_EQ(m.texture->width(), 8);
  EXPECT_EQ(m.texture->at(3, 2), (Rgb8{10, 200, 30}));
  for (const auto& n : m.normals) EXPECT_NEAR(n.norm(), 1.0, 1e-5);
  EXPECT_NEAR(m.surface_area(), 6.0, 1e-6);
  EXPECT_NEAR(m.diameter(), std::sqrt(3.0), 1e-6);
}

TEST(MeshIo, ObjMissingTextureStillLoadsWithMaterialColour) {
  const std::string dir = test::scratch_dir("objnotex");
  write_text(dir + "/cube.obj", kCubeObj);
  write_text(dir + "/cube.mtl", "newmtl boxmat\nKd 0.2 0.4 0.6\nmap_Kd missing.png\n");
  const TriangleMesh m = load_mesh(dir + "/cube.obj");
  EXPECT_FALSE(m.has_texture());
  EXPECT_EQ(m.base_color, (Rgb8{51, 102, 153}));
}

TEST(MeshIo, PlyRoundTripAsciiAndBinary) {
  TriangleMesh box = make_box(Eigen::Vector3f(0.2f, 0.1f, 0.05f), 0.04f);
  box.colors.resize(box.num_vertices());
  for (size_t i = 0; i < box.colors.size(); ++i)
    box.colors[i] = {static_cast<std::uint8_t>(i % 256), static_cast<std::uint8_t>((7 * i) % 256),
                     99};
  const std::string dir = test::scratch_dir("ply");
  for (bool binary : {false, true}) {
    PlyWriteOptions w;
    w.binary = binary;
    w.units_per_metre = 1000.0;
    const std::string path = dir + (binary ? "/b.ply" : "/a.ply");
    write_ply(path, box, w);
    MeshLoadOptions r;
    r.metres_per_unit = 0.001;
    const TriangleMesh m = load_mesh(path, r);
    ASSERT_EQ(m.num_vertices(), box.num_vertices());
    ASSERT_EQ(m.num_triangles(), box.num_triangles());
    for (size_t i = 0; i < m.num_vertices(); ++i) {
      ASSERT_LT((m.vertices[i] - box.vertices[i]).norm(), 1e-6) << "binary=" << binary;
      ASSERT_EQ(m.colors[i], box.colors[i]);
      ASSERT_LT((m.normals[i] - box.normals[i]).norm(), 1e-4);
    }
    EXPECT_EQ(m.triangles, box.triangles);
  }
}

TEST(MeshIo, PlyTextureReferenceAndBigEndian) {
  const std::string dir = test::scratch_dir("plytex");
  TriangleMesh quad = make_quad(1.0f, 1.0f, 2, 2);
  auto tex = std::make_shared<ColorImage>(4, 4, Rgb8{255, 0, 0});
  quad.texture = tex;
  write_color_png(dir + "/t.png", *tex);
  PlyWriteOptions w;
  w.texture_file = "t.png";
  write_ply(dir + "/q.ply", quad, w);
  const TriangleMesh m = load_ply(dir + "/q.ply", {0.001, true});
  ASSERT_TRUE(m.has_texture());
  EXPECT_EQ(m.uvs.size(), m.num_vertices());
  EXPECT_TRUE(m.colors.empty());  // dropped: the texture carries colour

  // Hand-made big-endian file: one triangle.
  std::string be =
      "ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  auto put_f = [&](float f) {
    std::uint32_t u;
    std::memcpy(&u, &f, 4);
    for (int s = 24; s >= 0; s -= 8) be.push_back(static_cast<char>((u >> s) & 0xff));
  };
  auto put_i = [&](std::int32_t i) {
    for (int s = 24; s >= 0; s -= 8)
      be.push_back(static_cast<char>((static_cast<std::uint32_t>(i) >> s) & 0xff));
  };
  for (float f : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 2.f, 0.f}) put_f(f);
  be.push_back(3);
  put_i(0), put_i(1), put_i(2);
  write_text(dir + "/be.ply", be);
  const TriangleMesh t = load_ply(dir + "/be.ply");
  ASSERT_EQ(t.num_triangles(), 1u);
  EXPECT_FLOAT_EQ(t.vertices[2].y(), 2.0f);
  EXPECT_NEAR(t.surface_area(), 1.0, 1e-9);
}

TEST(MeshIo, PlyWithoutColoursAndObjWithVertexColours) {
  const std::string dir = test::scratch_dir("plain");
  const TriangleMesh box = make_box(Eigen::Vector3f(0.1f, 0.1f, 0.1f), 0.05f);
  PlyWriteOptions w;
  w.write_colors = false;
  write_ply(dir + "/plain.ply", box, w);
  const TriangleMesh p = load_mesh(dir + "/plain.ply", {0.001, true});
  EXPECT_FALSE(p.has_colors());
  EXPECT_EQ(p.base_color, (Rgb8{255, 255, 255}));
  EXPECT_EQ(p.num_triangles(), box.num_triangles());
  write_text(dir + "/c.obj", "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nf 1 2 3\n");
  const TriangleMesh o = load_mesh(dir + "/c.obj");
  ASSERT_TRUE(o.has_colors());
  for (size_t i = 0; i < o.num_vertices(); ++i) {
    const Eigen::Vector3f v = o.vertices[i];
    const Rgb8 want = v.x() > 0.5f   ? Rgb8{0, 255, 0}
                      : v.y() > 0.5f ? Rgb8{0, 0, 255}
                                     : Rgb8{255, 0, 0};
    EXPECT_EQ(o.colors[i], want) << i;
  }
}

TEST(MeshIo, StlAndGltfWithANodeTransform) {
  const std::string dir = test::scratch_dir("stlgltf");
  write_text(dir + "/t.stl",
             "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 2 0 0\nvertex 0 1 0\n"
             "endloop\nendfacet\nendsolid t\n");
  const TriangleMesh stl = load_mesh(dir + "/t.stl", {0.5, true});
  ASSERT_EQ(stl.num_triangles(), 1u);
  EXPECT_NEAR(stl.surface_area(), 0.25, 1e-9);  // 1 m^2 in file units x 0.5^2
  // glTF: one triangle in a .bin buffer, placed by its node 10 units along +x.
  const float xyz[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const std::uint16_t idx[4] = {0, 1, 2, 0};
  std::string bin(reinterpret_cast<const char*>(xyz), sizeof(xyz));
  bin.append(reinterpret_cast<const char*>(idx), sizeof(idx));
  write_text(dir + "/tri.bin", bin);
  write_text(dir + "/tri.gltf", R"({"asset": {"version": "2.0"}, "scene": 0,
    "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, "translation": [10, 0, 0]}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
    "buffers": [{"uri": "tri.bin", "byteLength": 44}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                    {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                   "min": [0, 0, 0], "max": [1, 1, 0]},
                  {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}]})");
  const TriangleMesh g = load_mesh(dir + "/tri.gltf");
  ASSERT_EQ(g.num_triangles(), 1u);
  EXPECT_NEAR(g.bounds().min().x(), 10.0, 1e-6);
  EXPECT_NEAR(g.surface_area(), 0.5, 1e-9);
}

TEST(MeshIo, MalformedFilesThrowIoErrorNamingTheFile) {
  const std::string dir = test::scratch_dir("bad");
  struct Case {
    std::string name, text, expect;
  };
  const std::vector<Case> cases = {
      {"missing.obj", "", "not found"},
      {"badnum.obj", "v 0 0 zero\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "line 1: a vertex of 2 numbers"},
      {"badidx.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "out of range"},
      {"noface.obj", "v 0 0 0\nv 1 0 0\n", "no faces"},
      {"shortface.obj", "v 0 0 0\nv 1 0 0\nf 1 2\n", "cannot read mesh"},
      // assimp leaks the meshes it has built when a later one fails (fuzz mesh_obj finding 10):
      // a vertex index beyond the vertices, a negative one before the first, a line of 1 vertex
      {"leakidx.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no b\nf 1 2 4\n",
       "line 6: vertex index 4 is out of range (the file has 3 vertices)"},
      {"leakneg.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\ng b\nf -1 -2 -4\n",
       "line 6: vertex index -4 is out of range (3 vertices before it)"},
      {"leakline.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no b\nl 1\nf 1 2 3\n",
       "line 6: a line statement of one vertex"},
      // assimp splits lines where orpe's check must split them too
      {"nul.obj", std::string("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\0v 1 1 1\n", 40),
       "line 4: a NUL byte"},
      {"continued.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 \\\n 3\n", "line 4: a line continuation"},
      {"corner.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1/1/1 2 3\n",
       "line 4: the corner '1/1/1/1' is not v, v/vt, v//vn or v/vt/vn"},
      {"nomagic.ply", "hello\n", "magic"},
      {"noend.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n", "end_header"},
      {"trunc.ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty "
       "float z\n"
       "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n",
       "truncated"},
      {"short.ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty "
       "float z\n"
       "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 "
       "0 1 2 7\n",
       "line 13: more values than the element's properties"},
      {"badidx.ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty "
       "float z\n"
       "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 "
       "0 1 9\n",
       "out of range"},
      // libassimp aborts the process on a face without indices (fuzz finding, session 8).
      {"emptyface.ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty "
       "float z\n"
       "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 "
       "0\n0\n",
       "a face needs at least 3"},
      // a vertex record split over two lines: assimp reads line by line, so it took a later line
      // as a face of 0 indices and aborted (fuzz mesh_ply finding 26)
      {"splitrecord.ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty "
       "float z\n"
       "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0\n0\n1 0 0\n0 1 "
       "0\n3 0 1 2\n",
       "PLY body line 10: fewer values than the element's properties"},
      // records without properties take no bytes: assimp made an instance of each, and 1e9 of
      // them took over 10 s (fuzz mesh_ply finding 27); here a few that assimp reads as good
      {"noprops.ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty "
       "float z\nelement extra 1000\n"
       "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 "
       "0\n3 0 1 2\n",
       "PLY header line 7: element 'extra' declares 1000 records but no properties"},
      // a form feed: a line end to assimp, a space to orpe's reader; assimp aborted as for
      // splitrecord.ply (fuzz mesh_ply finding 29)
      {"formfeed.ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty "
       "float z\n"
       "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0\f0\n1 0 0\n0 1 "
       "0\n3 0 1 2\n",
       "PLY line 10: a control character (byte 0x0c)"},
      // assimp reads an element by its name and the first format line: two elements of one name
      // made it read out of bounds (fuzz mesh_ply finding 30); here one it reads as good
      {"twovertex.ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty "
       "float z\nelement face 1\nproperty list uchar int vertex_indices\nelement vertex 2\n"
       "property uchar red\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n5\n6\n",
       "PLY header line 9: a second element 'vertex' (the first is on line 3)"},
      {"twoformats.ply",
       "ply\nformat binary_little_endian 1.0\nformat ascii 1.0\nelement vertex 3\nproperty float "
       "x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int "
       "vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
       "PLY header line 3: a second format line"},
      // a colour of NaN: its cast to 8 bits was undefined behaviour (fuzz mesh_ply finding 32)
      {"nancolour.ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty "
       "float z\nproperty float red\nproperty float green\nproperty float blue\nelement face 1\n"
       "property list uchar int vertex_indices\nend_header\n0 0 0 nan 0 0\n1 0 0 1 1 1\n0 1 0 1 1 "
       "1\n3 0 1 2\n",
       "a vertex or material colour is not a number"},
      {"truncbin.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float "
       "y\n"
       "property float z\nend_header\n\x01\x02",
       "truncated"},
      // assimp would allocate for two billion vertices: refused from the header alone.
      {"huge.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 2000000000\nproperty float x\n"
       "property float y\nproperty float z\nend_header\n\x01\x02",
       "more than the"},
      {"cube.stl", "solid x\n", "no vertices"},
      {"cube.xyz3", "1 2 3\n", "unsupported"},
  };
  for (const auto& c : cases) {
    const std::string path = dir + "/" + c.name;
    if (c.name != "missing.obj") write_text(path, c.text);
    const std::string msg = expect_io_error(path, [&] { load_mesh(path); });
    EXPECT_NE(msg.find(c.expect), std::string::npos) << c.name << ": " << msg;
  }
}

// assimp writes a texture map or an `a...` statement before the first newmtl into the material it
// has not made: a null pointer, SIGSEGV (fuzz mesh_obj finding 28; the normal build too).
TEST(MeshIo, AMaterialLibraryStatementBeforeTheFirstMaterialIsAnErrorNamingItsLine) {
  const std::string dir = test::scratch_dir("badmtl");
  write_text(dir + "/tri.obj", "mtllib tri.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  const std::string mtl = dir + "/tri.mtl";
  struct Case {
    std::string text, expect;
  };
  for (const Case& c : std::vector<Case>{
           {"# a comment\n  map_Kd tex.png\nnewmtl a\n", "line 2: a texture map ('map_Kd') before"},
           {"aniso 0.5\nnewmtl a\nKd 1 0 0\n", "line 1: 'aniso' before the first newmtl"},
           {std::string("\xFF\xFEn\0e\0w\0", 8), "a UTF-16 or UTF-32 file"},
           // assimp leaked the stream of a file of 1-7 bytes (finding 34)
           {"ne 0 1\n", "7 bytes, too short for assimp's reader"}}) {
    write_text(mtl, c.text);
    const std::string msg = expect_io_error(mtl, [&] { load_mesh(dir + "/tri.obj"); });
    EXPECT_NE(msg.find(c.expect), std::string::npos) << msg;
  }
  // After the first material the same statements are read.
  write_text(mtl, "newmtl a\nKd 1 0 0\nmap_Kd missing.png\n");
  EXPECT_EQ(load_mesh(dir + "/tri.obj").num_triangles(), 1u);
}

// The texture a PLY names (comment TextureFile) with a name too long for the file system: the mesh
// without texture, as for a missing texture (fs::exists threw filesystem_error: fuzz mesh_ply
// finding 33).
TEST(MeshIo, ATextureNameTooLongForTheFileSystemLoadsTheMeshWithoutTexture) {
  const std::string path = test::scratch_dir("longtex") + "/tri.ply";
  write_text(path, "ply\nformat ascii 1.0\ncomment TextureFile " + std::string(300, 't') +
                       ".png\nelement vertex 3\nproperty float x\nproperty float y\nproperty "
                       "float z\nproperty float texture_u\nproperty float texture_v\nelement "
                       "face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 0 0\n1 "
                       "0 0 1 0\n0 1 0 0 1\n3 0 1 2\n");
  const TriangleMesh m = load_mesh(path);
  EXPECT_EQ(m.num_triangles(), 1u);
  EXPECT_FALSE(m.has_texture());
}

TEST(MeshIo, YcbBananaWithTexture) {
  ORPE_REQUIRE_DATA(data, "ycbv/models/011_banana/textured_simple.obj");
  const TriangleMesh m = load_mesh(data + "/ycbv/models/011_banana/textured_simple.obj");
  EXPECT_EQ(m.num_triangles(), 15728u);
  ASSERT_TRUE(m.has_texture());
  EXPECT_EQ(m.texture->width(), 4096);
  // The model points of the ADD metric lie on this mesh: same bounding box within a few mm.
  std::ifstream is(data + "/ycbv/models/011_banana/points.xyz");
  Eigen::AlignedBox3f pts;
  double x, y, z;
  while (is >> x >> y >> z)
    pts.extend(
        Eigen::Vector3f(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)));
  const auto b = m.bounds();
  EXPECT_LT((b.min() - pts.min()).cwiseAbs().maxCoeff(), 0.005);
  EXPECT_LT((b.max() - pts.max()).cwiseAbs().maxCoeff(), 0.005);
}

}  // namespace
}  // namespace orpe
