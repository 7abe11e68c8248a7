// decimate: quadric edge collapse (Garland & Heckbert) of a mesh to a fraction of its faces, keeping its
// topology, as CAD and mesh tools decimate: CGAL's Surface_mesh_simplification with the plane-quadric
// policies. Used once to make this folder's meshes (make_decimated.sh); not part of the build.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_simplification/Edge_collapse_visitor_base.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Count_ratio_stop_predicate.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/GarlandHeckbert_policies.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>

#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <iostream>

namespace SMS = CGAL::Surface_mesh_simplification;
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Mesh = CGAL::Surface_mesh<Kernel::Point_3>;

int main(int argc, char** argv) {
  if (argc != 4) {
    std::cerr << "usage: decimate IN.off OUT.off RATIO\n";
    return 2;
  }
  Mesh mesh;
  std::ifstream in(argv[1]);
  if (!(in >> mesh)) {
    std::cerr << "decimate: cannot read " << argv[1] << "\n";
    return 1;
  }
  const auto faces = mesh.number_of_faces();
  SMS::GarlandHeckbert_plane_policies<Mesh, Kernel> policies(mesh);
  // Edges fall with faces (E = 3F/2 on a closed mesh): a ratio of edges is the same ratio of faces.
  SMS::Count_ratio_stop_predicate<Mesh> stop(std::atof(argv[3]));
  SMS::edge_collapse(mesh, stop, CGAL::parameters::get_cost(policies.get_cost()).get_placement(policies.get_placement()));
  mesh.collect_garbage();
  std::ofstream out(argv[2]);
  out << std::setprecision(17);
  if (!(out << mesh)) {
    std::cerr << "decimate: cannot write " << argv[2] << "\n";
    return 1;
  }
  std::cout << argv[2] << ": " << faces << " -> " << mesh.number_of_faces() << " faces\n";
  return 0;
}
