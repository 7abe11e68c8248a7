// Points and rigid transforms in JSON: one spelling both ways, and what is not one refused.
#include "hal/description/eigen_json.hpp"

#include <gtest/gtest.h>

namespace cmm::description {
namespace {

using nlohmann::json;

TEST(EigenJson, PointsAndTransformsRoundTrip) {
  EXPECT_EQ(vec3_json(Eigen::Vector3d(1, -2.5, 3)), json::array({1, -2.5, 3}));
  EXPECT_EQ(vec3_from_json(json::array({1, -2.5, 3})), Eigen::Vector3d(1, -2.5, 3));
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(100, -20, 5);
  const json j = transform_json(T);
  ASSERT_EQ(j.size(), 4u);
  EXPECT_EQ(j[3], json::array({0.0, 0.0, 0.0, 1.0}));
  EXPECT_EQ(j[0][3], 100.0);  // row-major: the translation is the last column
  EXPECT_EQ(transform_from_json(j).matrix(), T.matrix());
}

TEST(EigenJson, RefusesWhatIsNotOne) {
  EXPECT_THROW(vec3_from_json(json::array({1, 2})), std::invalid_argument);
  EXPECT_THROW(vec3_from_json(json::array({1, 2, "z"})), std::invalid_argument);
  EXPECT_THROW(transform_from_json(json::array({json::array({1, 0, 0, 0})})), std::invalid_argument);
  json bad = transform_json(Eigen::Isometry3d::Identity());
  bad[3][0] = 1;
  EXPECT_THROW(transform_from_json(bad), std::invalid_argument);
}

}  // namespace
}  // namespace cmm::description
