// DMIS export of a planned move program (ANSI/DMIS 105.2 part 1, 5.x syntax), so that a CMM run by
// other software can take the same touches; the subset, sign conventions and an example: docs/dmis.md.
#pragma once

#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

#include "geometry/hole.hpp"
#include "hal/description/machine_description.hpp"
#include "planner/move_program.hpp"

namespace cmm::planner {

// One DMIS feature: the nominal a MEAS block measures, and the touches (Touch::id) that measure it.
struct DmisFeature {
  enum class Kind { point, circle };
  std::string label;  // [A-Z][A-Z0-9_]*, at most 16 characters (old DMIS versions' limit too), unique
  Kind kind = Kind::point;
  Vec3 nominal = Vec3::Zero();  // M, mm. point: on the part surface; circle: centre at the touches' depth
  Vec3 ijk = Vec3::UnitZ();     // unit. point: surface normal out of the material; circle: axis
  double diameter_mm = 0;       // circle only
  bool inner = true;            // circle only: a bore (INNER) or a boss (OUTER)
  std::vector<int> touch_ids;   // in the order they are measured
};

struct DmisOptions {
  std::string program_name = "cmmd";  // DMISMN text; anything but printable ASCII and ' becomes _
  std::string part_name = "part";     // FILNAM text; same rule
};

// Groups a program's touches into features the way the plan measures them: EDGE_<edge point> (the
// touches of one convex edge point), FACE_<edge point>_<face>, BORE_<hole> (a circle: from `holes`
// when the hole is there, else fitted to the touches), CORNER_<plate corner>_<face> and FIDUCIAL.
// A point's nominal is the mean of its touches' surface points, its ijk −normalize(Σ direction).
// Touches keep program order within a feature. Throws std::invalid_argument for a touch without
// its owner id.
std::vector<DmisFeature> dmis_features(const MoveProgram& program, const std::vector<geometry::Hole>& holes = {});

// Writes the program as DMIS: header, units, the active tip, then the program's motions in order —
// a GOTO for each move, a PTMEAS for each search (its SNSET distances the touch's) — each feature's
// touches inside its one FEAT and MEAS block. Every touch must be in exactly one feature, the
// touches of a feature one after the other in the program (build_program keeps them so), and each
// touch what the DME will do with its PTMEAS: unit direction, nominal centre = surface point −
// r·direction for the active tip's radius r, start on that line behind the contact. Anything else
// throws std::invalid_argument naming the touch or feature, before a byte is written.
void write_dmis(std::ostream& out, const MoveProgram& program, const description::MachineDescription& machine,
                const std::vector<DmisFeature>& features, const DmisOptions& options = {});

// The same, to `file`, written atomically (geometry/atomic_file.hpp), so a failed export never
// leaves half a program. Write errors throw geometry::FileError naming the file.
void write_dmis_file(const std::filesystem::path& file, const MoveProgram& program,
                     const description::MachineDescription& machine, const std::vector<DmisFeature>& features,
                     const DmisOptions& options = {});

}  // namespace cmm::planner
