#!/bin/sh
# Makes this folder's decimated variants of the analytic parts for the tessellation matrix
# (tests/planner/tessellation_matrix_test.cpp): each part's uniform 1 mm mesh cut to 10 % of its faces
# by quadric edge collapse, topology kept (decimate.cpp, on CGAL; apt-get install libcgal-dev). Run once
# from the repository root after a build:  sh tests/data/decimated/make_decimated.sh build/release
# (Open3D's simplify_quadric_decimation was tried first: on the boxes' planar grids it leaves
# non-manifold edges and folded faces, which no decimating tool users rely on would hand over.)
set -eu
build=$1
here=$(dirname "$0")
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
g++ -std=c++17 -O2 -I/usr/include/eigen3 "$here/decimate.cpp" -o "$tmp/decimate" -lgmp -lmpfr
for part in cube case3_block plate_with_holes bicone hemisphere_cone; do
  "$build/tests/make-analytic-part" "$part" --edge-length 1 -o "$tmp/$part.off" > /dev/null
  "$tmp/decimate" "$tmp/$part.off" "$here/$part.off" 0.1
done
