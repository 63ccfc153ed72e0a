#include "orpe/render/mesh_io.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>

#include <assimp/DefaultIOSystem.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <assimp/Importer.hpp>

#include "orpe/core/atomic_file.h"
#include "orpe/core/error.h"
#include "orpe/core/ply_format.h"
#include "orpe/render/obj_format.h"

namespace orpe {
namespace fs = std::filesystem;
namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

/// An 8-bit BGR image (OpenCV) as an RGB8 texture; nullptr (with a warning) when empty.
std::shared_ptr<const ColorImage> bgr_to_texture(const cv::Mat& m, const std::string& mesh_path,
                                                 const std::string& what) {
  if (m.empty() || m.depth() != CV_8U || m.channels() != 3) {
    spdlog::warn("{}: {} cannot be decoded; rendering without texture", mesh_path, what);
    return nullptr;
  }
  auto tex = std::make_shared<ColorImage>(m.cols, m.rows);
  for (int v = 0; v < m.rows; ++v) {
    const cv::Vec3b* row = m.ptr<cv::Vec3b>(v);
    Rgb8* out = tex->row(v);
    for (int u = 0; u < m.cols; ++u) out[u] = {row[u][2], row[u][1], row[u][0]};
  }
  return tex;
}

void note_file(const MeshLoadOptions& options, const std::string& path) {
  if (options.files_read) options.files_read->push_back(path);
}

/// Reads a texture file. Returns nullptr (with a warning) when missing or unreadable.
std::shared_ptr<const ColorImage> load_texture_image(const std::string& path,
                                                     const std::string& mesh_path,
                                                     const MeshLoadOptions& options) {
  note_file(options, path);
  const bool warn_missing = options.warn_missing_texture;
  std::error_code ec;  // fs::exists(path) threw for a name too long (fuzz mesh_ply finding 33)
  const bool exists = fs::exists(path, ec);
  if (ec) {
    spdlog::warn("{}: texture '{}' cannot be accessed ({}); rendering without texture", mesh_path,
                 path, ec.message());
    return nullptr;
  }
  if (!exists) {
    if (warn_missing)
      spdlog::warn("{}: texture '{}' not found; rendering without texture", mesh_path, path);
    return nullptr;
  }
  cv::Mat m;
  try {
    m = cv::imread(path, cv::IMREAD_COLOR);
  } catch (const cv::Exception&) {
  }
  return bgr_to_texture(m, mesh_path, "texture '" + path + "'");
}

void finish_mesh(TriangleMesh& mesh, const std::string& path) {
  if (mesh.normals.empty()) mesh.compute_vertex_normals();
  for (auto& n : mesh.normals) {
    const float len = n.norm();
    n = len > 0 && std::isfinite(len) ? Eigen::Vector3f(n / len) : Eigen::Vector3f::UnitZ();
  }
  std::string why;
  if (!mesh.IsValid(&why)) throw IoError(path, "invalid mesh: " + why);
  if (mesh.triangles.empty()) throw IoError(path, "mesh has no faces");
}

// ---------------------------------------------------------------------------------------------
// Reading through assimp. Everything assimp-specific stays in this file (mesh_io.h is assimp-free).

/// The texture image of a material: a file next to the mesh, or an embedded (compressed) image.
std::shared_ptr<const ColorImage> material_texture(const aiScene& scene, const aiMaterial& mat,
                                                   const std::string& mesh_path,
                                                   const MeshLoadOptions& options) {
  aiString rel;
  if (mat.GetTexture(aiTextureType_DIFFUSE, 0, &rel) != AI_SUCCESS &&
      mat.GetTexture(aiTextureType_BASE_COLOR, 0, &rel) != AI_SUCCESS)
    return nullptr;
  if (const aiTexture* emb = scene.GetEmbeddedTexture(rel.C_Str())) {
    if (emb->mHeight != 0) {  // raw ARGB8888 texels
      auto tex = std::make_shared<ColorImage>(static_cast<int>(emb->mWidth),
                                              static_cast<int>(emb->mHeight));
      for (unsigned y = 0; y < emb->mHeight; ++y)
        for (unsigned x = 0; x < emb->mWidth; ++x) {
          const aiTexel& t = emb->pcData[y * emb->mWidth + x];
          tex->at(static_cast<int>(x), static_cast<int>(y)) = {t.r, t.g, t.b};
        }
      return tex;
    }
    const cv::Mat buf(1, static_cast<int>(emb->mWidth), CV_8U, const_cast<aiTexel*>(emb->pcData));
    return bgr_to_texture(cv::imdecode(buf, cv::IMREAD_COLOR), mesh_path, "embedded texture");
  }
  std::string name = rel.C_Str();
  std::replace(name.begin(), name.end(), '\\', '/');
  const std::string path = (fs::path(mesh_path).parent_path() / name).string();
  return load_texture_image(path, mesh_path, options);
}

/// An 8-bit channel of a colour in [0, 1]. A channel that is not a number (assimp passes a file's
/// NaN through; the cast was undefined behaviour: fuzz mesh_ply finding 32) is an error naming
/// the file.
std::uint8_t quantise01(float x, const std::string& path) {
  if (std::isnan(x)) throw IoError(path, "a vertex or material colour is not a number");
  return static_cast<std::uint8_t>(std::clamp(x, 0.0f, 1.0f) * 255.0f + 0.5f);
}

Rgb8 quantise01(const aiColor4D& c, const std::string& path) {
  return {quantise01(c.r, path), quantise01(c.g, path), quantise01(c.b, path)};
}

/// The diffuse colour of a material, or nullopt for assimp's default material (file without one).
std::optional<Rgb8> material_colour(const aiMaterial& mat, const std::string& path) {
  aiString name;
  if (mat.Get(AI_MATKEY_NAME, name) == AI_SUCCESS && name == aiString(AI_DEFAULT_MATERIAL_NAME))
    return std::nullopt;
  aiColor4D kd;
  if (mat.Get(AI_MATKEY_COLOR_DIFFUSE, kd) != AI_SUCCESS &&
      mat.Get(AI_MATKEY_BASE_COLOR, kd) != AI_SUCCESS)
    return std::nullopt;
  return quantise01(kd, path);
}

/// One aiMesh (triangles only, after aiProcess_SortByPType) placed by its node's transform.
struct PlacedMesh {
  const aiMesh* mesh;
  aiMatrix4x4 T_file_mesh;
};

void collect_meshes(const aiScene& scene, const aiNode& node, const aiMatrix4x4& T_file_parent,
                    std::vector<PlacedMesh>& out) {
  const aiMatrix4x4 T = T_file_parent * node.mTransformation;
  for (unsigned i = 0; i < node.mNumMeshes; ++i) {
    const aiMesh* m = scene.mMeshes[node.mMeshes[i]];
    if (m->mPrimitiveTypes & aiPrimitiveType_TRIANGLE) out.push_back({m, T});
  }
  for (unsigned c = 0; c < node.mNumChildren; ++c)
    collect_meshes(scene, *node.mChildren[c], T, out);
}

/// Appends one placed mesh's vertices and triangles (uvs and colours only when `textured` /
/// the mesh has them; `face_colour` fills colours for a mesh without vertex colours).
void append_placed(const PlacedMesh& pm, float scale, bool want_uv, TriangleMesh& out,
                   std::vector<Rgb8>& colours, std::vector<bool>& has_colour, bool& all_normals) {
  const aiMesh& m = *pm.mesh;
  const int base = static_cast<int>(out.vertices.size());
  aiMatrix3x3 R(pm.T_file_mesh);
  R.Inverse().Transpose();
  all_normals &= m.HasNormals();
  for (unsigned i = 0; i < m.mNumVertices; ++i) {
    const aiVector3D p = pm.T_file_mesh * m.mVertices[i];
    out.vertices.emplace_back(p.x * scale, p.y * scale, p.z * scale);
    const aiVector3D n = m.HasNormals() ? R * m.mNormals[i] : aiVector3D(0, 0, 1);
    out.normals.emplace_back(n.x, n.y, n.z);
    if (want_uv) {
      const aiVector3D t = m.HasTextureCoords(0) ? m.mTextureCoords[0][i] : aiVector3D();
      out.uvs.emplace_back(t.x, t.y);
    }
    if (m.HasVertexColors(0)) {
      colours.push_back(quantise01(m.mColors[0][i], out.name));  // out.name: the file
    } else {
      colours.push_back({255, 255, 255});
    }
    has_colour.push_back(m.HasVertexColors(0));
  }
  for (unsigned f = 0; f < m.mNumFaces; ++f) {
    const aiFace& face = m.mFaces[f];
    if (face.mNumIndices != 3) continue;  // points and lines of a mixed mesh
    out.triangles.emplace_back(base + static_cast<int>(face.mIndices[0]),
                               base + static_cast<int>(face.mIndices[1]),
                               base + static_cast<int>(face.mIndices[2]));
  }
}

/// Colours without a texture (the rules of mesh_io.h): vertex colours when the file has any, else
/// the materials' diffuse colours per vertex when they differ, else one base colour.
void assign_colours(const std::vector<PlacedMesh>& placed, const aiScene& scene,
                    const std::vector<Rgb8>& vertex_colours, const std::vector<bool>& has_colour,
                    TriangleMesh& mesh) {
  if (std::find(has_colour.begin(), has_colour.end(), true) != has_colour.end()) {
    mesh.colors = vertex_colours;
    return;
  }
  std::vector<std::optional<Rgb8>> kd;
  for (const auto& pm : placed)
    kd.push_back(material_colour(*scene.mMaterials[pm.mesh->mMaterialIndex], mesh.name));
  const bool varies = std::any_of(kd.begin(), kd.end(), [&](const auto& c) {
    return c.value_or(Rgb8{255, 255, 255}) != kd.front().value_or(Rgb8{255, 255, 255});
  });
  if (varies) {
    for (size_t i = 0; i < placed.size(); ++i)
      mesh.colors.insert(mesh.colors.end(), placed[i].mesh->mNumVertices,
                         kd[i].value_or(Rgb8{255, 255, 255}));
  } else if (!kd.empty() && kd.front()) {
    mesh.base_color = *kd.front();
  }
}

/// assimp's file access while it reads a mesh: every file it looks for or opens is noted in
/// `files_read` (when set). For an OBJ (`check_mtl`), every file it opens (the mesh and its
/// material libraries, wherever its path search finds them) is checked by detail::mtl_problem
/// first; after a problem it opens nothing more, and read_with_assimp throws the problem.
class CheckedMeshFiles : public Assimp::DefaultIOSystem {
 public:
  CheckedMeshFiles(bool check_mtl, std::vector<std::string>* files_read)
      : check_mtl_(check_mtl), files_read_(files_read) {}
  bool Exists(const char* file) const override {
    if (files_read_) files_read_->push_back(file);
    return DefaultIOSystem::Exists(file);
  }
  Assimp::IOStream* Open(const char* file, const char* mode) override {
    if (problem) return nullptr;
    if (files_read_) files_read_->push_back(file);
    if (!check_mtl_) return DefaultIOSystem::Open(file, mode);
    if (std::ifstream is{file, std::ios::binary}) {
      const std::string text{std::istreambuf_iterator<char>(is), std::istreambuf_iterator<char>()};
      if (const auto why = detail::mtl_problem(text)) {
        problem = IoError(file, *why);
        return nullptr;
      }
    }
    return DefaultIOSystem::Open(file, mode);
  }
  std::optional<IoError> problem;

 private:
  bool check_mtl_;
  std::vector<std::string>* files_read_;
};

TriangleMesh read_with_assimp(const std::string& path, const MeshLoadOptions& options) {
  note_file(options, path);
  if (!fs::exists(path)) throw IoError(path, "file not found");
  if (fs::is_directory(path)) throw IoError(path, "is a folder, expected a mesh file");
  if (!(options.metres_per_unit > 0) || !std::isfinite(options.metres_per_unit))
    throw IoError(path, "metres_per_unit must be positive");
  Assimp::Importer importer;
  const std::string ext = lower(fs::path(path).extension().string());
  if (ext.empty() || !importer.IsExtensionSupported(ext))
    throw IoError(path,
                  "unsupported mesh format '" + ext +
                      "' (expected .obj, .ply, .stl, .gltf, .glb, .dae, ... as assimp reads)");
  if (ext == ".ply") detail::check_ply_structure(path);
  if (ext == ".obj") detail::check_obj_structure(path);
  CheckedMeshFiles* obj_files = nullptr;
  if (ext == ".obj" || options.files_read)  // the importer owns the handler
    importer.SetIOHandler(obj_files = new CheckedMeshFiles(ext == ".obj", options.files_read));
  // Points and lines are dropped; polygons are fan-triangulated; corners with the same position,
  // normal, uv and colour share one vertex (as an indexed OBJ/PLY file means them).
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE,
                              aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  const aiScene* scene =
      importer.ReadFile(path, aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                                  aiProcess_SortByPType | aiProcess_ValidateDataStructure);
  if (obj_files && obj_files->problem) throw *obj_files->problem;
  if (!scene) throw IoError(path, std::string("cannot read mesh: ") + importer.GetErrorString());
  if (!scene->mRootNode || scene->mNumMeshes == 0) throw IoError(path, "mesh has no faces");
  std::vector<PlacedMesh> placed;
  collect_meshes(*scene, *scene->mRootNode, aiMatrix4x4(), placed);
  if (placed.empty()) throw IoError(path, "mesh has no faces");

  TriangleMesh mesh;
  mesh.name = path;
  // One texture per TriangleMesh: the first textured material's (the others keep their uvs).
  bool any_uv = false;
  for (const auto& pm : placed) any_uv |= pm.mesh->HasTextureCoords(0);
  if (options.load_texture && any_uv)
    for (const auto& pm : placed) {
      if (!pm.mesh->HasTextureCoords(0)) continue;
      mesh.texture =
          material_texture(*scene, *scene->mMaterials[pm.mesh->mMaterialIndex], path, options);
      if (mesh.texture) break;
    }
  std::vector<Rgb8> colours;
  std::vector<bool> has_colour;
  bool all_normals = true;
  const float scale = static_cast<float>(options.metres_per_unit);
  for (const auto& pm : placed)
    append_placed(pm, scale, mesh.texture != nullptr, mesh, colours, has_colour, all_normals);
  for (const auto& v : mesh.vertices)
    if (!v.allFinite()) throw IoError(path, "a vertex has a non-finite coordinate");
  if (!all_normals) mesh.normals.clear();
  if (!mesh.texture) assign_colours(placed, *scene, colours, has_colour, mesh);
  finish_mesh(mesh, path);
  return mesh;
}

}  // namespace

TriangleMesh load_mesh(const std::string& path, const MeshLoadOptions& options) {
  return read_with_assimp(path, options);
}

TriangleMesh load_obj(const std::string& path, const MeshLoadOptions& options) {
  if (lower(fs::path(path).extension().string()) != ".obj")
    throw IoError(path, "load_obj: expected a .obj file");
  return read_with_assimp(path, options);
}

TriangleMesh load_ply(const std::string& path, const MeshLoadOptions& options) {
  if (lower(fs::path(path).extension().string()) != ".ply")
    throw IoError(path, "load_ply: expected a .ply file");
  return read_with_assimp(path, options);
}

void write_ply(const std::string& path, const TriangleMesh& mesh, const PlyWriteOptions& opt) {
  std::string why;
  if (!mesh.IsValid(&why)) throw IoError(path, "cannot write invalid mesh: " + why);
  TriangleMesh m = mesh;
  if (opt.write_normals && m.normals.empty()) m.compute_vertex_normals();
  const bool with_uv = !opt.texture_file.empty() && !m.uvs.empty();
  std::vector<Rgb8> colors;
  if (opt.write_colors) {
    if (m.has_texture()) bake_texture_into_vertex_colors(m);
    if (!m.colors.empty())
      colors = m.colors;
    else
      colors.assign(m.vertices.size(), Rgb8{255, 255, 255});
    // Base colour multiplies in.
    for (auto& c : colors) {
      auto mul = [](std::uint8_t a, std::uint8_t b) {
        return static_cast<std::uint8_t>((a * b + 127) / 255);
      };
      c = {mul(c.r, m.base_color.r), mul(c.g, m.base_color.g), mul(c.b, m.base_color.b)};
    }
  }
  const double s = opt.units_per_metre;
  write_file_atomic(
      path,
      [&](std::ostream& os) {
        os << "ply\nformat " << (opt.binary ? "binary_little_endian" : "ascii") << " 1.0\n";
        os << "comment orpe TriangleMesh, units per metre " << s << "\n";
        if (with_uv) os << "comment TextureFile " << opt.texture_file << "\n";
        os << "element vertex " << m.vertices.size() << "\n";
        os << "property float x\nproperty float y\nproperty float z\n";
        if (opt.write_normals) os << "property float nx\nproperty float ny\nproperty float nz\n";
        if (opt.write_colors)
          os << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
        if (with_uv) os << "property float texture_u\nproperty float texture_v\n";
        os << "element face " << m.triangles.size() << "\n";
        os << "property list uchar int vertex_indices\nend_header\n";
        if (opt.binary) {
          static_assert(std::endian::native == std::endian::little,
                        "binary PLY writer assumes little endian");
          auto put = [&](const auto& v) { os.write(reinterpret_cast<const char*>(&v), sizeof(v)); };
          for (size_t i = 0; i < m.vertices.size(); ++i) {
            const Eigen::Vector3f p = (m.vertices[i].cast<double>() * s).cast<float>();
            put(p.x()), put(p.y()), put(p.z());
            if (opt.write_normals)
              put(m.normals[i].x()), put(m.normals[i].y()), put(m.normals[i].z());
            if (opt.write_colors) put(colors[i].r), put(colors[i].g), put(colors[i].b);
            if (with_uv) put(m.uvs[i].x()), put(m.uvs[i].y());
          }
          for (const auto& t : m.triangles) {
            const std::uint8_t three = 3;
            put(three), put(t[0]), put(t[1]), put(t[2]);
          }
        } else {
          char buf[256];
          for (size_t i = 0; i < m.vertices.size(); ++i) {
            const Eigen::Vector3d p = m.vertices[i].cast<double>() * s;
            int n = std::snprintf(buf, sizeof(buf), "%.7g %.7g %.7g", p.x(), p.y(), p.z());
            os.write(buf, n);
            if (opt.write_normals) {
              n = std::snprintf(buf, sizeof(buf), " %.5f %.5f %.5f", m.normals[i].x(),
                                m.normals[i].y(), m.normals[i].z());
              os.write(buf, n);
            }
            if (opt.write_colors) {
              n = std::snprintf(buf, sizeof(buf), " %d %d %d", colors[i].r, colors[i].g,
                                colors[i].b);
              os.write(buf, n);
            }
            if (with_uv) {
              n = std::snprintf(buf, sizeof(buf), " %.6f %.6f", m.uvs[i].x(), m.uvs[i].y());
              os.write(buf, n);
            }
            os.put('\n');
          }
          for (const auto& t : m.triangles) {
            const int n = std::snprintf(buf, sizeof(buf), "3 %d %d %d\n", t[0], t[1], t[2]);
            os.write(buf, n);
          }
        }
      },
      opt.binary);
}

}  // namespace orpe
