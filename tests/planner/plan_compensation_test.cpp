// A whole plan compensated: touches swept exactly against the TRUE analytic part (placed in M by a
// non-identity T_M_S) with 1 µm trigger noise give edge points within 10 µm of the analytic edges and
// bores within a few µm of the true diameters; bad touches fail their feature only; the CSV reads
// back, the JSON holds what docs/result.md lists, the merged cloud holds scan and probe points.
#include <unistd.h>

#include "planner/plan_compensation.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <memory>
#include <numbers>
#include <set>

#include "edge_truth.hpp"
#include "geometry/analytic_parts.hpp"
#include "planner/measured_cloud.hpp"
#include "planner/result_csv.hpp"
#include "planner/result_json.hpp"
#include "true_part_touches.hpp"

namespace cmm::planner {
namespace {

using geometry::AnalyticPart;
using geometry::testing::nearest_true_edge;
constexpr double deg = std::numbers::pi / 180;
constexpr double kSigma = 0.001;  // trigger noise, mm per axis
constexpr double kRadius = 1.0;

// DESIGN.md's target for a measured edge point.
constexpr double kEdgeTolerance = 0.010;

struct Scenario {
  std::string name;
  AnalyticPart truth;  // in S; at 0.25 mm, so its circles' chords stay within 2.6 µm of the circles
  geometry::TriangleMesh reference;
  geometry::FeatureModel model;
  Eigen::Isometry3d T_M_S;
  MeasurementPlan plan;
  std::map<int, TouchOutcome> touches;  // from the true part, with trigger noise
  int missed = 0;
};

// noise_mm 0: the reference is the true part meshed at 1 mm; else that mesh with Gaussian vertex noise.
// δ is 0.1 mm on an exact reference and 0.2 mm on a noisy one; `window` may change the window options.
std::unique_ptr<Scenario> make_scenario(const std::string& name, const std::function<AnalyticPart(double)>& make,
                                        double noise_mm, const std::function<void(WindowOptions&)>& window = {}) {
  auto s = std::make_unique<Scenario>();
  s->name = name;
  s->truth = make(0.25);
  s->reference = noise_mm > 0 ? geometry::with_gaussian_noise(make(1.0).mesh, noise_mm, 20261124) : make(1.0).mesh;
  geometry::FeatureModelOptions features;
  features.spacing = 4;
  s->model = geometry::extract_features(s->reference, features);
  s->T_M_S = testing::tilted_machine_pose();
  description::MachineDescription machine = description::default_machine();
  machine.tips.front().ball_radius_mm = kRadius;
  machine.tips.front().shaft_length_mm = 60;  // reaches the foot of the block's walls
  MeasurementPlanOptions options;
  options.touch.radius = kRadius;
  options.touch.delta = noise_mm > 0 ? 0.2 : 0.1;
  if (window) window(options.touch.window);
  s->plan = plan_measurement(s->model, s->reference, s->T_M_S, machine, options);
  testing::TrueTouches touches = testing::touch_true_part(s->truth.mesh, s->T_M_S, s->plan, kRadius, kSigma, 20260611);
  s->touches = std::move(touches.outcomes);
  s->missed = touches.missed;
  return s;
}

const Scenario& scenario(const std::string& name) {
  static std::map<std::string, std::unique_ptr<Scenario>> cache;
  auto& slot = cache[name];
  if (!slot) {
    const auto case3 = [](double h) { return geometry::make_case3_block(h); };
    const auto plate = [](double h) { return geometry::make_plate_with_holes(h); };
    if (name == "case3_block") slot = make_scenario(name, case3, 0);
    if (name == "case3_block_noisy") slot = make_scenario(name, case3, 0.1);
    // Windows of at least 80° half-angle: none is wide enough, and every edge is measured on its faces.
    if (name == "case3_block_faces")
      slot = make_scenario(name, case3, 0, [](WindowOptions& w) { w.min_half_angle_deg = 80; });
    if (name == "plate_with_holes") slot = make_scenario(name, plate, 0);
    if (name == "plate_with_holes_noisy") slot = make_scenario(name, plate, 0.1);
  }
  return *slot;
}

MeasurementResult compensate(const Scenario& s, const std::map<int, TouchOutcome>& touches) {
  return compensate_plan(s.model, s.plan, s.T_M_S, touches, {kRadius, kSigma});
}

const geometry::TrueHole* true_hole_of(const AnalyticPart& truth, const Vec3& centre, const Vec3& axis) {
  const geometry::TrueHole* best = nullptr;
  double best_distance = 1e300;
  for (const geometry::TrueHole& h : truth.holes) {
    const Vec3 v = centre - h.centre;
    const double across = (v - v.dot(axis) * axis).norm();
    if (across < best_distance) best_distance = across, best = &h;
  }
  return best_distance < 1 ? best : nullptr;
}

class PlanCompensation : public ::testing::TestWithParam<std::string> {};

TEST_P(PlanCompensation, MeasuredEdgesAndBoresMatchTheAnalyticTruth) {
  const Scenario& s = scenario(GetParam());
  const MeasurementResult result = compensate(s, s.touches);
  ASSERT_EQ(result.edges.size(), s.model.points.size());
  ASSERT_EQ(result.holes.size(), s.model.holes.size());

  int planned = 0, two_touch = 0, faces = 0;
  std::map<std::string, int> not_planned_reasons;
  double worst = 0, worst_over_sigma = 0, worst_sigma = 0;
  for (const EdgeResult& e : result.edges) {
    if (e.method == EdgeMethod::none) {
      EXPECT_EQ(e.status, FeatureStatus::not_planned) << e.id;
      EXPECT_FALSE(e.reason.empty()) << e.id;
      ++not_planned_reasons[e.reason.substr(0, 240)];
      continue;
    }
    ++planned;
    ASSERT_EQ(e.status, FeatureStatus::measured) << s.name << " point " << e.id << ": " << e.reason;
    (e.method == EdgeMethod::two_touch ? two_touch : faces)++;
    EXPECT_EQ(e.scan->frame, PointFrame::scan);
    EXPECT_EQ(e.machine->frame, PointFrame::machine);
    EXPECT_LE((s.T_M_S * e.scan->position - e.machine->position).norm(), 1e-9) << e.id;
    const double error = nearest_true_edge(s.truth, e.scan->position).distance;
    worst = std::max(worst, error);
    worst_sigma = std::max(worst_sigma, e.scan->sigma_mm);
    worst_over_sigma = std::max(worst_over_sigma, error / e.scan->sigma_mm);
    EXPECT_LE(error, kEdgeTolerance) << s.name << " point " << e.id << " (" << to_string(e.method) << ", σ "
                                     << e.scan->sigma_mm * 1e3 << " µm): measured " << e.scan->position.transpose()
                                     << " is " << error * 1e3 << " µm off the true edge";
    // The deviation is the measured point against the reference, across the edge.
    const Vec3 d = e.scan->position - e.reference;
    const Vec3 t = s.model.points[static_cast<std::size_t>(e.id)].tangent;
    EXPECT_NEAR(std::abs(e.deviation.signed_mm), (d - d.dot(t) * t).norm(), 1e-9) << e.id;
  }
  int bores = 0;
  double worst_diameter = 0, worst_centre = 0;
  for (const HoleResult& h : result.holes) {
    if (h.status == FeatureStatus::not_planned) continue;
    ++bores;
    ASSERT_EQ(h.status, FeatureStatus::measured) << s.name << " hole " << h.id << ": " << h.reason;
    const geometry::TrueHole* truth = true_hole_of(s.truth, h.scan->centre, h.nominal_axis);
    ASSERT_NE(truth, nullptr) << "hole " << h.id << " at " << h.scan->centre.transpose();
    const double diameter_error = h.scan->diameter_mm - 2 * truth->radius;
    const Vec3 v = h.scan->centre - truth->centre;
    const Vec3 axis = truth->axis.normalized();
    const double centre_error = (v - v.dot(axis) * axis).norm();
    worst_diameter = std::max(worst_diameter, std::abs(diameter_error));
    worst_centre = std::max(worst_centre, centre_error);
    // The true mesh's wall is a polygon inscribed in the circle: its flats lie up to the sagitta
    // h²/8R inside it (2.6 µm for Ø6 at 0.25 mm), so the ball finds the bore up to 2 sagittas small.
    const double sagitta = 0.25 * 0.25 / (8 * truth->radius);
    EXPECT_LE(std::abs(diameter_error), 2 * sagitta + 0.003) << s.name << " hole " << h.id << " Ø" << 2 * truth->radius;
    EXPECT_LE(centre_error, 0.003) << s.name << " hole " << h.id;
    EXPECT_EQ(h.wall_points.size(), h.touch_ids.size());
  }

  const ResultSummary& sum = result.summary;
  EXPECT_EQ(sum.edges_measured, planned);
  EXPECT_EQ(sum.edges_failed, 0);
  EXPECT_EQ(sum.holes_measured, bores);
  EXPECT_EQ(sum.holes_failed, 0);
  EXPECT_DOUBLE_EQ(sum.worst_sigma_mm, worst_sigma);
  EXPECT_EQ(s.missed, 0);
  EXPECT_TRUE(result.notes.empty());
  EXPECT_GT(planned, 100);
  EXPECT_GE(bores, 1);
  std::printf("[ %s ] %zu edge points: %d measured (%d two-touch, %d faces), %d not planned; worst error %.4f um "
              "(%.2f sigma), worst sigma %.4f um; %d of %zu holes bored: worst diameter error %.4f um, centre %.4f um; "
              "rms deviation from the reference %.4f mm\n",
              s.name.c_str(), result.edges.size(), planned, two_touch, faces, sum.edges_not_planned, worst * 1e3,
              worst_over_sigma, worst_sigma * 1e3, bores, result.holes.size(), worst_diameter * 1e3, worst_centre * 1e3,
              sum.rms_deviation_mm);
  for (const auto& [reason, count] : not_planned_reasons) std::printf("    %4d not planned: %s\n", count, reason.c_str());
}

INSTANTIATE_TEST_SUITE_P(AnalyticParts, PlanCompensation,
                         ::testing::Values("case3_block", "case3_block_noisy", "case3_block_faces", "plate_with_holes",
                                           "plate_with_holes_noisy"),
                         [](const auto& info) { return info.param; });

// The first planned edge point of a method, and the first bored hole.
const EdgePlan& first_planned(const Scenario& s, EdgeMethod method, std::size_t skip = 0) {
  for (const EdgePlan& e : s.plan.edges)
    if (e.method == method && skip-- == 0) return e;
  throw std::runtime_error("no edge point planned with " + std::string(to_string(method)));
}

const BorePlan& first_bore(const Scenario& s) {
  for (const BorePlan& b : s.plan.bores)
    if (b.planned) return b;
  throw std::runtime_error("no bore planned");
}

TEST(PlanCompensationFailures, BadTouchesFailTheirFeatureOnlyWithTheReason) {
  const Scenario& s = scenario("plate_with_holes");
  std::map<int, TouchOutcome> touches = s.touches;
  const EdgePlan& missing = first_planned(s, EdgeMethod::two_touch, 0);
  const EdgePlan& missed = first_planned(s, EdgeMethod::two_touch, 1);
  const EdgePlan& wrong = first_planned(s, EdgeMethod::two_touch, 2);
  const BorePlan& bore = first_bore(s);
  touches.erase(missing.touches[1].id);
  touches[missed.touches[0].id].contact = false;
  touches[wrong.touches[0].id].centre -= 3 * wrong.touches[0].direction;  // 3 mm short: the circles no longer meet
  touches.erase(bore.touches[3].id);
  touches[987654] = {true, Vec3::Zero()};  // a result the plan has no touch for

  MeasurementResult result;
  ASSERT_NO_THROW(result = compensate(s, touches));
  const auto edge = [&](int id) { return result.edges.at(static_cast<std::size_t>(id)); };
  const std::string missing_touch = "touch " + std::to_string(missing.touches[1].id) + " ";
  EXPECT_EQ(edge(missing.edge_point).status, FeatureStatus::failed);
  EXPECT_NE(edge(missing.edge_point).reason.find(missing_touch), std::string::npos) << edge(missing.edge_point).reason;
  EXPECT_NE(edge(missing.edge_point).reason.find("has no result"), std::string::npos);
  EXPECT_EQ(edge(missed.edge_point).status, FeatureStatus::failed);
  EXPECT_NE(edge(missed.edge_point).reason.find("missed"), std::string::npos) << edge(missed.edge_point).reason;
  EXPECT_EQ(edge(wrong.edge_point).status, FeatureStatus::failed);
  EXPECT_NE(edge(wrong.edge_point).reason.find("edge point " + std::to_string(wrong.edge_point) + ":"), std::string::npos)
      << edge(wrong.edge_point).reason;
  EXPECT_FALSE(edge(wrong.edge_point).scan.has_value());
  const HoleResult& hole = result.holes.at(static_cast<std::size_t>(bore.hole));
  EXPECT_EQ(hole.status, FeatureStatus::failed);
  EXPECT_NE(hole.reason.find("touch " + std::to_string(bore.touches[3].id) + " (bore 3) has no result"), std::string::npos)
      << hole.reason;

  const MeasurementResult clean = compensate(s, s.touches);
  EXPECT_EQ(result.summary.edges_failed, 3);
  EXPECT_EQ(result.summary.edges_measured, clean.summary.edges_measured - 3);
  EXPECT_EQ(result.summary.holes_failed, 1);
  EXPECT_EQ(result.summary.holes_measured, clean.summary.holes_measured - 1);
  ASSERT_EQ(result.notes.size(), 1u);
  EXPECT_NE(result.notes[0].find("987654"), std::string::npos) << result.notes[0];

  // With no touches at all, every planned feature fails and nothing throws.
  const MeasurementResult none = compensate(s, {});
  EXPECT_EQ(none.summary.edges_measured, 0);
  EXPECT_EQ(none.summary.edges_failed, clean.summary.edges_measured);
  EXPECT_EQ(none.summary.holes_failed, clean.summary.holes_measured);
  EXPECT_EQ(none.summary.max_deviation_id, -1);
}

TEST(PlanCompensationFailures, APlanOfAnotherModelIsRefused) {
  const Scenario& s = scenario("plate_with_holes");
  geometry::FeatureModel other = s.model;
  other.points.pop_back();
  EXPECT_THROW(compensate_plan(other, s.plan, s.T_M_S, s.touches, {kRadius, kSigma}), std::invalid_argument);
  EXPECT_THROW(compensate_plan(s.model, s.plan, s.T_M_S, s.touches, {0, kSigma}), std::invalid_argument);
}

// RFC 4180 reader: quoted fields may hold commas, doubled quotes and line breaks.
std::vector<std::vector<std::string>> parse_csv(const std::string& text) {
  std::vector<std::vector<std::string>> rows(1, std::vector<std::string>(1));
  bool quoted = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (quoted) {
      if (c == '"' && i + 1 < text.size() && text[i + 1] == '"') rows.back().back() += '"', ++i;
      else if (c == '"') quoted = false;
      else rows.back().back() += c;
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      rows.back().emplace_back();
    } else if (c == '\n') {
      rows.emplace_back(1);
    } else {
      rows.back().back() += c;
    }
  }
  if (rows.back().size() == 1 && rows.back().front().empty()) rows.pop_back();
  return rows;
}

TEST(ResultExport, CsvReadsBackRowForRow) {
  const Scenario& s = scenario("plate_with_holes");
  std::map<int, TouchOutcome> touches = s.touches;
  touches.erase(first_planned(s, EdgeMethod::two_touch).touches[0].id);
  MeasurementResult result = compensate(s, touches);
  result.edges[0].reason = "a reason, with \"quotes\"\nand a second line";

  const auto rows = parse_csv(to_csv(result));
  ASSERT_EQ(rows.size(), result.edges.size() + 1);
  EXPECT_EQ(rows[0], (std::vector<std::string>{"id", "kind", "method", "status", "x_S", "y_S", "z_S", "x_M", "y_M", "z_M",
                                               "deviation_mm", "sigma_mm", "nominal_deviation_mm", "uncertainty_mm",
                                               "tolerance_lower_mm", "tolerance_upper_mm", "verdict", "reason"}));
  std::map<std::string, int> statuses;
  for (std::size_t i = 0; i < result.edges.size(); ++i) {
    const EdgeResult& e = result.edges[i];
    const std::vector<std::string>& row = rows[i + 1];
    ASSERT_EQ(row.size(), 18u) << "row " << i + 1;
    EXPECT_EQ(row[0], std::to_string(e.id));
    EXPECT_EQ(row[1], geometry::to_string(e.kind));
    EXPECT_EQ(row[2], to_string(e.method));
    EXPECT_EQ(row[3], to_string(e.status));
    EXPECT_EQ(row[17], e.reason);
    for (std::size_t cell = 12; cell < 17; ++cell) EXPECT_EQ(row[cell], "") << "no nominal, no inspection cells";
    ++statuses[row[3]];
    if (e.status != FeatureStatus::measured) {
      for (int k = 4; k < 12; ++k) EXPECT_EQ(row[static_cast<std::size_t>(k)], "") << "row " << i + 1 << " column " << k;
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(std::stod(row[static_cast<std::size_t>(4 + k)]), e.scan->position(k), 0.5e-6);
      EXPECT_NEAR(std::stod(row[static_cast<std::size_t>(7 + k)]), e.machine->position(k), 0.5e-6);
    }
    EXPECT_NEAR(std::stod(row[10]), e.deviation.signed_mm, 0.5e-6);
    EXPECT_NEAR(std::stod(row[11]), e.scan->sigma_mm, 0.5e-6);
  }
  EXPECT_EQ(statuses["measured"], result.summary.edges_measured);
  EXPECT_EQ(statuses["failed"], result.summary.edges_failed);
  EXPECT_EQ(statuses["not_planned"], result.summary.edges_not_planned);
  EXPECT_EQ(statuses["failed"], 1);

  const auto holes = parse_csv(holes_to_csv(result));
  ASSERT_EQ(holes.size(), result.holes.size() + 1);
  ASSERT_EQ(holes[0].size(), 27u);
  EXPECT_EQ(holes[0][8], "diameter_mm");
  EXPECT_EQ(holes[0][15], "diameter_nominal_deviation_mm");
  EXPECT_EQ(holes[0][25], "verdict");
  for (std::size_t i = 0; i < result.holes.size(); ++i) {
    const HoleResult& h = result.holes[i];
    ASSERT_EQ(holes[i + 1].size(), 27u);
    EXPECT_EQ(holes[i + 1][1], to_string(h.status));
    EXPECT_NEAR(std::stod(holes[i + 1][9]), h.nominal_diameter_mm, 0.5e-6);
    EXPECT_EQ(holes[i + 1][26], h.reason);
    if (h.status != FeatureStatus::measured) continue;
    EXPECT_NEAR(std::stod(holes[i + 1][8]), h.scan->diameter_mm, 0.5e-6);
    EXPECT_NEAR(std::stod(holes[i + 1][10]), h.diameter_deviation_mm, 0.5e-6);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(std::stod(holes[i + 1][static_cast<std::size_t>(2 + k)]), h.scan->centre(k), 0.5e-6);
  }
}

std::string read_text(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Every key the JSON has, at any depth, must be named in docs/result.md (as `key`), and the
// values must be those of the result.
TEST(ResultExport, JsonHoldsTheDocumentedFields) {
  const Scenario& s = scenario("plate_with_holes");
  std::map<int, TouchOutcome> touches = s.touches;
  const EdgePlan& failed = first_planned(s, EdgeMethod::two_touch);
  touches.erase(failed.touches[0].id);
  const MeasurementResult result = compensate(s, touches);
  const nlohmann::json j = to_json(result);

  EXPECT_EQ(j.at("schema"), "cmmd.result/1");
  EXPECT_EQ(j.at("units"), "mm");
  EXPECT_EQ(j.at("frame"), "S");
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) EXPECT_EQ(j.at("T_M_S")[r][c].get<double>(), s.T_M_S.matrix()(r, c));
  EXPECT_EQ(j.at("probe").at("ball_radius_mm"), kRadius);
  EXPECT_EQ(j.at("summary").at("edge_points").at("measured"), result.summary.edges_measured);
  EXPECT_EQ(j.at("summary").at("holes").at("measured"), result.summary.holes_measured);
  ASSERT_EQ(j.at("edge_points").size(), result.edges.size());
  ASSERT_EQ(j.at("holes").size(), result.holes.size());
  for (std::size_t i = 0; i < result.edges.size(); ++i) {
    const EdgeResult& e = result.edges[i];
    const nlohmann::json& p = j["edge_points"][i];
    EXPECT_EQ(p.at("id"), e.id);
    EXPECT_EQ(p.at("status"), to_string(e.status));
    EXPECT_EQ(p.at("touches").get<std::vector<int>>(), e.touch_ids);
    if (e.status == FeatureStatus::measured) {
      for (int k = 0; k < 3; ++k) {
        EXPECT_EQ(p.at("measured_S").at("position")[k].get<double>(), e.scan->position(k));
        EXPECT_EQ(p.at("measured_M").at("position")[k].get<double>(), e.machine->position(k));
      }
      EXPECT_EQ(p.at("deviation_mm").get<double>(), e.deviation.signed_mm);
      EXPECT_EQ(p.at("sigma_mm").get<double>(), e.scan->sigma_mm);
    } else {
      EXPECT_TRUE(p.at("measured_S").is_null());
      EXPECT_TRUE(p.at("deviation_mm").is_null());
      EXPECT_TRUE(p.at("reason").is_string());
    }
  }
  EXPECT_TRUE(j["edge_points"][static_cast<std::size_t>(failed.edge_point)].at("reason").is_string());
  for (std::size_t i = 0; i < result.holes.size(); ++i) {
    const HoleResult& h = result.holes[i];
    const nlohmann::json& o = j["holes"][i];
    if (h.status != FeatureStatus::measured) continue;
    EXPECT_EQ(o.at("diameter_mm").get<double>(), h.scan->diameter_mm);
    EXPECT_EQ(o.at("diameter_deviation_mm").get<double>(), h.diameter_deviation_mm);
    EXPECT_EQ(o.at("nominal").at("diameter_mm").get<double>(), h.nominal_diameter_mm);
  }
  // A round trip through text keeps every double exactly.
  EXPECT_EQ(nlohmann::json::parse(j.dump()), j);

  const std::string doc = read_text(std::filesystem::path(CMMD_SOURCE_DIR) / "docs" / "result.md");
  ASSERT_FALSE(doc.empty());
  std::set<std::string> keys;
  const std::function<void(const nlohmann::json&)> collect = [&](const nlohmann::json& v) {
    if (v.is_object())
      for (const auto& [key, value] : v.items()) keys.insert(key), collect(value);
    if (v.is_array())
      for (const auto& value : v) collect(value);
  };
  collect(j);
  for (const std::string& key : keys) EXPECT_NE(doc.find("`" + key + "`"), std::string::npos) << "docs/result.md lacks `" << key << "`";
}

TEST(ResultExport, MergedCloudHoldsTheScanAndTheMeasuredPoints) {
  const Scenario& s = scenario("plate_with_holes");
  const MeasurementResult result = compensate(s, s.touches);
  const std::vector<MeasuredPoint> measured = measured_points_in_scan(result);
  std::size_t wall = 0;
  for (const HoleResult& h : result.holes) wall += h.wall_points.size();
  ASSERT_EQ(measured.size(), static_cast<std::size_t>(result.summary.edges_measured) + wall);
  ASSERT_GT(wall, 0u);
  const auto dir = std::filesystem::temp_directory_path() / ("cmmd_plan_compensation_test_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const auto file = dir / "merged.ply";
  write_merged_ply(file, s.reference.vertices, measured, 0.1);
  const std::string bytes = read_text(file);
  const std::string count = "element vertex " + std::to_string(s.reference.vertices.rows() + static_cast<Eigen::Index>(measured.size())) + "\n";
  EXPECT_NE(bytes.find(count), std::string::npos);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace cmm::planner
