// Mesh files <-> TriangleMesh. Units are converted at this edge: vertices come out in metres.
//
// Reading goes through assimp (Debian's libassimp): OBJ with MTL (Kd, map_Kd) and vertex colours,
// PLY (ascii / binary, vertex colours, texture_u/v, `comment TextureFile X`), STL, glTF/GLB, DAE
// and the other formats assimp reads. Polygons are fan-triangulated, node transforms applied,
// points and lines dropped. One texture per mesh: the first textured material's (a file next to the
// mesh, or an image embedded in glTF/GLB); a missing texture file is a warning, not an error (the
// YCB models ship textures for only some objects). With a texture, vertex colours are dropped (they
// are usually the texture's bake and would darken it twice); without one, vertex colours when the
// file has any, else the materials' diffuse colours per vertex when they differ, else one base
// colour. A PLY file's header and body are checked by orpe's point-cloud PLY reader first
// (core/ply_format.h). Malformed input throws orpe::IoError naming the file and the problem as
// assimp reports it. assimp's headers stay in mesh_io.cpp.
#pragma once

#include <string>
#include <vector>

#include "orpe/render/mesh.h"

namespace orpe {

struct MeshLoadOptions {
  /// Metres per file unit: 1 for files in metres (YCB OBJ), 0.001 for millimetres (BOP PLY).
  double metres_per_unit = 1.0;
  bool load_texture = true;  ///< read the texture image referenced by the file, when present
  bool warn_missing_texture = true;  ///< warn when the referenced texture file does not exist
  /// When set, receives the path of every file the load read or looked for: the mesh, its material
  /// libraries and texture image, also those that did not exist (a cache of what the mesh gives
  /// must know all its inputs: pipeline/model_cache.h). In the order met; may repeat a path.
  std::vector<std::string>* files_read = nullptr;
};

/// Loads an OBJ or PLY file (by extension, case-insensitive). Normals are computed when the file
/// has none. Throws IoError for a missing, unreadable or malformed file, or an unsupported
/// extension.
TriangleMesh load_mesh(const std::string& path, const MeshLoadOptions& options = {});
TriangleMesh load_obj(const std::string& path, const MeshLoadOptions& options = {});
TriangleMesh load_ply(const std::string& path, const MeshLoadOptions& options = {});

struct PlyWriteOptions {
  double units_per_metre = 1000.0;  ///< 1000 writes millimetres (BOP models)
  bool write_normals = true;
  bool write_colors =
      true;  ///< vertex colours (the mesh's colours, else its texture baked, else base colour)
  std::string
      texture_file;  ///< when non-empty and the mesh has uvs: texture_u/v + `comment TextureFile`
  bool binary = false;  ///< binary_little_endian instead of ascii
};

/// Writes a PLY file atomically. Throws IoError on failure.
void write_ply(const std::string& path, const TriangleMesh& mesh,
               const PlyWriteOptions& options = {});

}  // namespace orpe
