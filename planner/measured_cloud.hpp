// The job's merged cloud: the scan's points and the probe's measured points in one PLY, each point
// tagged with where it came from and how well it is known, so a viewer can colour or filter by both.
#pragma once

#include <filesystem>
#include <vector>

#include "geometry/mesh.hpp"
#include "planner/edge_compensation.hpp"

namespace cmm::planner {

inline constexpr unsigned char merged_source_scan = 0;
inline constexpr unsigned char merged_source_measured = 1;

// Binary little-endian PLY, one vertex element: double x y z, uchar source (0 scan, 1 measured),
// float uncertainty_mm (scan points: `scan_uncertainty_mm`, e.g. the scanner's 1-σ noise; measured
// points: their sigma_mm). Scan points come first, in order, then the measured ones.
// Everything is in the scan frame S: measured points must have been through to_scan_frame, else
// CompensationError names the first one in M. Written atomically (geometry/atomic_file.hpp), so a
// reader never sees half a file; I/O failures throw geometry::FileError.
void write_merged_ply(const std::filesystem::path& path, const geometry::Points& scan_points,
                      const std::vector<MeasuredPoint>& measured, double scan_uncertainty_mm);

}  // namespace cmm::planner
