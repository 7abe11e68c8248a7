// Fuzzes feature extraction (geometry/feature_model.hpp) on any mesh a reader accepts: an OFF text,
// as an uploaded model reaches cmm-plan and cmmd, past the model limits both apply. Every edge point
// must come out finite (position, normals, their uncertainties, its position error and δ), whatever
// the tessellation: slivers, fans, stacked vertices, folded or open surfaces. Refusals: FileError from
// the reader, ModelRefused from the limits, TooManyPoints from the extractor.
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "fuzz_support.hpp"
#include "geometry/edge_point.hpp"
#include "geometry/feature_model.hpp"
#include "geometry/file_error.hpp"
#include "geometry/off_io.hpp"
#include "hal/description/machine_description.hpp"
#include "planner/model_limits.hpp"

namespace {

bool finite(const cmm::geometry::Vec3& v) { return v.allFinite(); }

bool sound(const cmm::geometry::EdgePoint& p) {
  const bool numbers = std::isfinite(p.n_up_uncertainty_rad) && p.n_up_uncertainty_rad >= 0 &&
                       std::isfinite(p.n_down_uncertainty_rad) && p.n_down_uncertainty_rad >= 0 &&
                       std::isfinite(p.position_sigma_mm) && p.position_sigma_mm >= 0 &&
                       std::isfinite(p.mesh_deviation_mm) && p.mesh_deviation_mm >= 0 &&
                       std::isfinite(cmm::geometry::delta_at(p, 0.1));
  return numbers && finite(p.position) && finite(p.n_up) && finite(p.tangent) && (!p.n_down || finite(*p.n_down));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace cmm;
  fuzz::refusing_with<geometry::FileError, planner::ModelRefused, geometry::TooManyPoints>([&] {
    const geometry::ReadResult read = geometry::read_off("fuzz.off", fuzz::text_of(data, size));
    const auto* mesh = std::get_if<geometry::TriangleMesh>(&read.model);
    if (!mesh) return;
    planner::check_model_limits(*mesh, description::default_machine().travel_box, "fuzz.off");
    const geometry::FeatureModel model = geometry::extract_features(*mesh);
    if (!std::isfinite(model.point_sigma_mm) || !std::isfinite(model.features.noise.sigma_mm)) __builtin_trap();
    for (const geometry::EdgePoint& p : model.points)
      if (!sound(p)) __builtin_trap();
  });
  return 0;
}
