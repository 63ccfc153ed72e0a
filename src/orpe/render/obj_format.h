// An OBJ mesh's statements checked before assimp reads it (render/mesh_io.cpp), split into lines
// and words as assimp 5.2's OBJ importer splits them. assimp leaks the meshes it has already built
// when a later mesh fails ("vertex index out of range", or a line statement of one vertex):
// harmless once in a program, but LeakSanitizer stops on it (fuzz finding 10, docs/FUZZING.md), and
// no valid file has it. The other statements (materials, groups, texture coordinates, normals)
// stay assimp's to read.
#pragma once

#include <string>

namespace orpe::detail {

/// Throws IoError naming the file and the line for: a NUL or form-feed byte; a line continuation
/// ('\' at the end of a line); free-form geometry (`cstype`); a face, line or point statement whose
/// corners are not v, v/vt, v//vn or v/vt/vn of whole numbers other than 0 (at most 9 digits); a
/// vertex index beyond the file's vertices (a negative one: beyond the vertices before it); a line
/// statement of one vertex.
void check_obj_structure(const std::string& path);

}  // namespace orpe::detail
