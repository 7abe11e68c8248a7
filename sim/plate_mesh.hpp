// The base plate as a solid mesh in its own frame P, fiducial included, so the simulated probe
// touches the same plate the registration measures (hal/description/plate.hpp).
#pragma once

#include "geometry/mesh.hpp"
#include "hal/description/plate.hpp"

namespace cmm::sim {

// A chamfer fiducial cuts its corner; a hole fiducial must go through the plate, and then the plate
// must be an axis-aligned rectangle (what geometry::mesh_box_with_holes meshes). Anything else
// throws std::invalid_argument saying what is not simulated.
geometry::TriangleMesh plate_mesh(const description::Plate& plate);

}  // namespace cmm::sim
