// What the simulated probe can touch, in M: the true part on its base plate, and the reference sphere
// (analytic, so qualification is exact). Contact is the stylus ball swept exactly against them.
#pragma once

#include <memory>
#include <optional>

#include <Eigen/Geometry>

#include "geometry/ball_sweep.hpp"
#include "geometry/mesh.hpp"

namespace cmm::sim {

using geometry::Vec3;

struct Scene {
  geometry::TriangleMesh part;   // in M
  geometry::TriangleMesh plate;  // in M
  Vec3 sphere_centre = Vec3::Zero();
  double sphere_radius = 0;
  Eigen::Isometry3d T_M_P = Eigen::Isometry3d::Identity();     // plate frame into M
  Eigen::Isometry3d T_M_Part = Eigen::Isometry3d::Identity();  // the part's own frame into M
};

// The transformed copy of a mesh (normals too, if it has them).
geometry::TriangleMesh transformed(const geometry::TriangleMesh& mesh, const Eigen::Isometry3d& T);

class SceneContact {
 public:
  explicit SceneContact(const Scene& scene);

  // The first contact of a ball of `radius` moving from `start` along unit `direction` for at most
  // `max_travel` mm, against the part, the plate and the sphere: the travel and the centre there.
  struct Hit {
    double travel = 0;
    Vec3 centre = Vec3::Zero();
  };
  std::optional<Hit> first_hit(const Vec3& start, const Vec3& direction, double max_travel, double radius) const;

 private:
  geometry::BallSweeper solids_;
  Vec3 sphere_centre_;
  double sphere_radius_;
};

}  // namespace cmm::sim
