// Mesh files <-> TriangleMesh. Units are converted at this edge: vertices come out in metres.
//
// OBJ: `v x y z [r g b]`, `vt`, `vn`, polygonal `f` (fan-triangulated; v, v/vt, v//vn, v/vt/vn,
//      negative indices), `mtllib` + `usemtl` with `Kd` and `map_Kd` (one texture per mesh: the
//      first textured material's). A missing texture file is a warning, not an error (the YCB
//      models ship textures for only some objects). Vertex colours are kept only when no texture is
//      loaded.
// PLY: ascii, binary_little_endian and binary_big_endian; vertex x y z, optional nx ny nz,
//      red green blue [alpha] (uchar, or float in [0, 1]), texture_u/texture_v (or u/v, s/t);
//      faces as a list property (vertex_indices / vertex_index), polygons fan-triangulated;
//      per-face `texcoord` lists are supported (vertices are then split per corner); `comment
//      TextureFile X` loads the texture X next to the file (vertex colours are then dropped: they
//      are usually the texture's bake and would darken it twice). Other elements are skipped.
// Malformed input throws orpe::IoError naming the file and the problem (and line, for text
// formats).
#pragma once

#include <string>

#include "orpe/render/mesh.h"

namespace orpe {

struct MeshLoadOptions {
  /// Metres per file unit: 1 for files in metres (YCB OBJ), 0.001 for millimetres (BOP PLY).
  double metres_per_unit = 1.0;
  bool load_texture = true;  ///< read the texture image referenced by the file, when present
  bool warn_missing_texture = true;  ///< warn when the referenced texture file does not exist
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
