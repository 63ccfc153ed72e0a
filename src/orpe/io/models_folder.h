// `dataset.models_dir` (`--models DIR`): a folder of object meshes that replaces a dataset's own
// models, for any layout. Rules (docs/DATASETS.md, "Your own object models"):
//  - one mesh file per object (DIR/mug.obj, DIR/box.ply, ... any format load_mesh reads), or one
//    folder per object (DIR/mug/ with textured_simple.obj or textured.obj, else its only mesh file;
//    an optional points.xyz there gives the registration / evaluation points, as in YCB-Video);
//  - class names are the file (or folder) names without extension; class ids: the dataset's id of
//    the same class name, else the number of a name obj_NNNNNN or NNNNNN, else the next free id in
//    sorted name order;
//  - unit: `dataset.models_unit` m | mm, or detected from the meshes' bounding-box diagonals (all
//    within 0.01-5 -> m, all within 10-5000 -> mm; anything else is an error asking for the unit);
//  - symmetry is detected from the model (pose stage) unless DIR/symmetry.yaml states it per
//  object:
//    `name: none | auto | symmetric | continuous x|y|z | flip x [y] [z]` (symmetric: the detected
//    group, scored with ADD-S, as YCB-Video's symmetric classes).
#pragma once

#include <string>

#include "orpe/io/dataset.h"

namespace orpe {

/// Replaces the models of `info` (points, meshes, units, names of the folder's classes, symmetric
/// classes) with those of `dir`. Throws IoError naming the folder or file for a missing folder, no
/// meshes, a folder with several candidate meshes, an unclear unit, or a bad symmetry.yaml.
void apply_models_folder(DatasetInfo& info, const std::string& dir, const std::string& unit);

/// Parses one symmetry statement (`none`, `auto`, `symmetric`, `continuous z`, `flip x y`); nullopt for `auto`.
/// Throws std::invalid_argument explaining what is expected.
std::optional<ModelSymmetrySpec> parse_symmetry_spec(const std::string& text);

}  // namespace orpe
