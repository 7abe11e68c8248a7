// geometry's write_cloud has no per-point attributes, so this writes its own small PLY: the header
// as text, the body as one packed record per vertex, written atomically.
#include "planner/measured_cloud.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>

#include "geometry/atomic_file.hpp"

namespace cmm::planner {

namespace {

static_assert(std::numeric_limits<double>::is_iec559 && std::numeric_limits<float>::is_iec559);

template <typename T>
void append_little_endian(std::string& out, T value) {
  unsigned char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  if constexpr (std::endian::native == std::endian::big) std::reverse(bytes, bytes + sizeof(T));
  out.append(reinterpret_cast<const char*>(bytes), sizeof(T));
}

void append_vertex(std::string& out, const double* xyz, unsigned char source, double uncertainty_mm) {
  for (int k = 0; k < 3; ++k) append_little_endian(out, xyz[k]);
  out.push_back(static_cast<char>(source));
  append_little_endian(out, static_cast<float>(uncertainty_mm));
}

}  // namespace

void write_merged_ply(const std::filesystem::path& path, const geometry::Points& scan_points,
                      const std::vector<MeasuredPoint>& measured, double scan_uncertainty_mm) {
  for (const MeasuredPoint& point : measured) {
    const char* feature = point.method == MeasurementMethod::bore_wall ? "hole" : "edge point";
    if (point.frame != PointFrame::scan) {
      throw CompensationError(feature, point.id, CompensationError::Reason::bad_input,
                              "measured point still in the machine frame; map it with to_scan_frame first");
    }
    if (!point.position.allFinite()) {
      throw CompensationError(feature, point.id, CompensationError::Reason::bad_input, "measured point is not finite");
    }
  }

  const std::size_t count = static_cast<std::size_t>(scan_points.rows()) + measured.size();
  std::string bytes =
      "ply\n"
      "format binary_little_endian 1.0\n"
      "comment cmmd merged cloud: scan points (source 0) and probe-measured points (source 1), mm, frame S\n"
      "element vertex " +
      std::to_string(count) +
      "\n"
      "property double x\n"
      "property double y\n"
      "property double z\n"
      "property uchar source\n"
      "property float uncertainty_mm\n"
      "end_header\n";
  constexpr std::size_t record = 3 * sizeof(double) + 1 + sizeof(float);
  bytes.reserve(bytes.size() + count * record);
  for (Eigen::Index i = 0; i < scan_points.rows(); ++i) {
    append_vertex(bytes, scan_points.row(i).data(), merged_source_scan, scan_uncertainty_mm);
  }
  for (const MeasuredPoint& point : measured) {
    append_vertex(bytes, point.position.data(), merged_source_measured, point.sigma_mm);
  }

  geometry::write_atomically(path, bytes);
}

}  // namespace cmm::planner
