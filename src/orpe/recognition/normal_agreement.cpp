#include "orpe/recognition/normal_agreement.h"

namespace orpe {

std::vector<Eigen::Vector3f> kept_cell_normals(const SceneGrid& g, int radius) {
  GridNormals normals(g, radius);
  std::vector<Eigen::Vector3f> out(g.points.size(), Eigen::Vector3f::Zero());
  for (size_t c = 0; c < out.size(); ++c)
    if (g.kept[c]) out[c] = normals.at(static_cast<int>(c));
  return out;
}

}  // namespace orpe
