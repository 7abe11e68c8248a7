// PCD, the Point Cloud Library's format (versions 0.5 to 0.7): DATA ascii, binary and binary_compressed
// (LZF), any field order; x y z and, when all three are there, normal_x normal_y normal_z are read.
#pragma once

#include <filesystem>
#include <ostream>
#include <string_view>

#include "geometry/mesh_io.hpp"

namespace cmm::geometry {

// `bytes` is the whole file, `file` names it in errors (the line in the header and in ASCII data, the
// byte in binary data). Every other field (rgb, intensity, curvature, padding "_", ...) is skipped by
// its SIZE × COUNT. An organized cloud (HEIGHT > 1) marks a pixel without a return with NaN
// coordinates: such points are dropped and counted in ReadReport::points_without_return; a NaN or
// infinity anywhere else is refused. VIEWPOINT (tx ty tz qw qx qy qz) is the sensor's pose in the
// cloud's frame, with the points stored in the sensor frame (PCL's viewer places them so): when it is
// not the identity the points are moved by it and the normals turned by it (ReadReport::viewpoint_applied).
ReadResult read_pcd(const std::filesystem::path& file, std::string_view bytes);

enum class PcdEncoding { ascii, binary };
// float32 is what PCL's point types hold (a float64 x does not map onto pcl::PointXYZ, so PCL's tools
// would read nothing); float64 round-trips exactly.
enum class PcdScalar { float32, float64 };

// An unorganized cloud (HEIGHT 1), identity VIEWPOINT, fields x y z and normal_x normal_y normal_z when
// the cloud has normals.
void write_pcd(std::ostream& out, const PointCloud& cloud, PcdEncoding encoding = PcdEncoding::binary,
               PcdScalar scalar = PcdScalar::float32);

}  // namespace cmm::geometry
