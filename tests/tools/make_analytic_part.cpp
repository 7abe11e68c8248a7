// make-analytic-part: writes one of the analytic test parts as a mesh file, optionally with Gaussian
// noise, so tests (and the README's sample) can run the real cmm-plan binary on a known part.
#include <CLI/CLI.hpp>
#include <iostream>

#include "geometry/analytic_parts.hpp"
#include "geometry/mesh_io.hpp"

int main(int argc, char** argv) {
  using namespace cmm::geometry;
  CLI::App app{"write an analytic test part (mm) as STL/PLY/OBJ/OFF"};
  std::string name, output;
  double edge_length = 2, sigma = 0;
  std::uint64_t seed = 1;
  bool open_bores = false;
  std::string style = "uniform";
  Tessellation tessellation;
  app.add_option("PART", name, "cube, case3_block, plate_with_holes, plate_small_openings, bicone or hemisphere_cone")->required();
  app.add_option("-o,--output", output, "file to write; the format follows the extension")->required();
  app.add_option("--edge-length", edge_length, "target mesh edge length, mm")->check(CLI::PositiveNumber);
  app.add_option("--tessellation", style, "uniform, cad or slivers")->check(CLI::IsMember({"uniform", "cad", "slivers"}));
  app.add_option("--chord-tolerance", tessellation.chord_tolerance, "cad and slivers: largest facet distance from a curved face, mm")
      ->check(CLI::PositiveNumber);
  app.add_option("--noise", sigma, "Gaussian noise sigma on every coordinate, mm")->check(CLI::NonNegativeNumber);
  app.add_option("--seed", seed, "noise seed");
  app.add_flag("--open-bores", open_bores, "drop the bore walls, as a scan from above loses them");
  CLI11_PARSE(app, argc, argv);
  AnalyticPart part;
  try {
    tessellation.edge_length = edge_length;
    tessellation.style = style == "cad"       ? Tessellation::Style::cad
                         : style == "slivers" ? Tessellation::Style::slivers
                                              : Tessellation::Style::uniform;
    part = make_analytic_part(name, tessellation);
  } catch (const std::invalid_argument& e) {
    std::cerr << "make-analytic-part: " << e.what() << "\n";
    return 2;
  }
  if (open_bores) {
    // A bore wall face has its normal across the hole axis and lies within the hole radius + ε.
    TriangleMesh& m = part.mesh;
    int kept = 0;
    for (int f = 0; f < m.faces.rows(); ++f) {
      const Vec3 a = vertex(m, m.faces(f, 0)), b = vertex(m, m.faces(f, 1)), c = vertex(m, m.faces(f, 2));
      const Vec3 centroid = (a + b + c) / 3, normal = (b - a).cross(c - a).normalized();
      bool wall = false;
      for (const TrueHole& hole : part.holes) {
        Vec3 radial = centroid - hole.centre;
        radial -= radial.dot(hole.axis) * hole.axis;
        wall = wall || (std::abs(normal.dot(hole.axis)) < 0.1 && radial.norm() < hole.radius * 1.001);
      }
      if (!wall) m.faces.row(kept++) = m.faces.row(f);
    }
    m.faces.conservativeResize(kept, 3);
  }
  if (sigma > 0) part.mesh = with_gaussian_noise(part.mesh, sigma, seed);
  write_mesh(output, part.mesh);
  std::cout << output << ": " << name << ", " << part.mesh.faces.rows() << " triangles\n";
  return 0;
}
