// docs/SEMANTIC.md, "Evidence across keyframes": the minimal width of a model (the height above
// its support that semantic.min_height_fraction compares an instance with) is its smallest extent.
#include <gtest/gtest.h>

#include "orpe/pipeline/object_models.h"

namespace orpe {
namespace {

TEST(ModelMinWidth, IsTheSmallestExtentOfABoxInAnyOrientation) {
  ObjectModel box;
  for (int i = 0; i <= 10; ++i)
    for (int j = 0; j <= 10; ++j)
      for (int k = 0; k <= 10; ++k)
        box.points.emplace_back(0.2f * i / 10 - 0.1f, 0.1f * j / 10, 0.04f * k / 10);
  EXPECT_NEAR(model_min_width_m(box), 0.04, 0.0005);
  // Rotated about the x axis by 30 degrees: the width does not depend on the model's frame.
  const Eigen::Matrix3f R =
      Eigen::AngleAxisf(static_cast<float>(M_PI / 6), Eigen::Vector3f::UnitX()).toRotationMatrix();
  for (auto& p : box.points) p = R * p;
  EXPECT_NEAR(model_min_width_m(box), 0.04, 0.0005);
  EXPECT_EQ(model_min_width_m(ObjectModel{}), 0.0);
}

}  // namespace
}  // namespace orpe
