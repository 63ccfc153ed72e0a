// An OBJ mesh's statements checked before assimp reads it (render/mesh_io.cpp), split into lines
// and words as assimp 5.2's OBJ importer splits them. assimp leaks the meshes it has already built
// when a later mesh fails ("vertex index out of range", or a line statement of one vertex):
// harmless once in a program, but LeakSanitizer stops on it (fuzz finding 10, docs/FUZZING.md), and
// no valid file has it. The other statements (materials, groups, texture coordinates, normals)
// stay assimp's to read.
#pragma once

#include <optional>
#include <string>

namespace orpe::detail {

/// Throws IoError naming the file and the line for: a NUL or form-feed byte; a line continuation
/// ('\' at the end of a line); free-form geometry (`cstype`); a vertex (`v`) of other than 3, 4
/// or 6 numbers (assimp skips it); a face, line or point statement whose
/// corners are not v, v/vt, v//vn or v/vt/vn of whole numbers other than 0 (at most 9 digits); a
/// vertex index beyond the file's vertices (a negative one: beyond the vertices before it); a line
/// statement of one vertex.
void check_obj_structure(const std::string& path);

/// The first statement of a material library (an OBJ's .mtl, `text` as assimp 5.2's MTL reader
/// reads it) that would crash assimp: an `a...` statement or a texture map (map_Kd, bump, norm,
/// disp, ...) before the first `newmtl`, which assimp writes into the material it has not made (a
/// null pointer: fuzz mesh_obj finding 28); a UTF-16 or UTF-32 byte-order mark (assimp converts
/// such a file first); a text of 1 to 7 bytes (assimp throws on it and leaks the stream it opened:
/// finding 34). "line N: ..." (or the short text's size) or nullopt.
std::optional<std::string> mtl_problem(const std::string& text);

}  // namespace orpe::detail
