// Whether a model stands where the job says it stands, before anything moves: on the base plate,
// inside the corners the request gives in S, at a size a part on that plate can have. A model in
// inches, centimetres or metres read as mm fails that, and the unit factor that makes it stand
// (25.4, 10, 1000, or their inverses for a model scaled too much) names the mistake.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "geometry/mesh.hpp"
#include "hal/description/plate.hpp"

namespace cmm::planner {

struct ModelUnitsOptions {
  // How far the model's points may reach beyond the corners' polygon, and below the plate's bottom
  // (a scan that caught the plate's top edge), before they count as off the plate.
  double margin_mm = 5;
  // A part smaller than this fraction of the plate's shortest side is not a plausible part for that
  // plate: 15 mm on the 200 × 150 mm default plate. A real one that small takes the override.
  double min_part_fraction = 0.1;
  // Points beyond the margin a model may have and still stand: a raw scan's strays.
  double outlier_fraction = 0.01;
  // At most this many points are looked at (every n-th one): the verdict is a matter of percent.
  std::size_t max_points = 200'000;
};

struct ModelUnits {
  Eigen::Vector3d extent_mm = Eigen::Vector3d::Zero();  // the bounding box's size as given (after scale)
  bool corners_known = false;  // the plate's corners in S were given: the position was checked too
  bool stands = true;          // as given
  // When it does not stand: the factor its coordinates need to stand (> 1: the model is that many
  // times too small), or none when no unit factor helps.
  std::optional<double> factor;
  std::string problem;             // empty when it stands; else why, naming the factor and the scale to use
  std::vector<std::string> notes;  // what was not checked, and why
};

// `points_S` are the model's points in S, in mm after `scale` (a mesh's vertices, a raw scan's points
// before meshing); `source` names the model in messages ("part.stl (scale 1)"). `T_S_P` is where the
// request's corners put the plate in S (planner::fit_plate_pose on the scan corners), none when the
// request gives no corners: then only the size is checked against the plate and the notes say so.
// The factor test multiplies the coordinates, position included: a model exported in inches from
// the same CAD frame has every coordinate divided by 25.4.
ModelUnits check_model_units(const geometry::Points& points_S, double scale, const std::string& source,
                             const description::Plate& plate, const std::optional<Eigen::Isometry3d>& T_S_P,
                             const ModelUnitsOptions& options = {});

}  // namespace cmm::planner
