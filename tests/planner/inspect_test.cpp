// Inspection against a nominal: the ISO 14253-1 rule at its limits, tolerance overrides, the nominal's
// edges and holes found on a CAD export of few huge triangles, deviations against known offsets, the
// job verdict, the tolerances' one JSON form with its error paths, and the result's CSV and JSON.
#include "planner/inspect.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "geometry/analytic_parts.hpp"
#include "planner/inspection_json.hpp"
#include "planner/result_csv.hpp"
#include "planner/result_json.hpp"
#include "planner/tolerances_json.hpp"

namespace cmm::planner {
namespace {

TEST(DecisionRule, PassFailUndecidedAtTheLimits) {
  const ToleranceZone zone{-0.1, 0.1};
  EXPECT_EQ(decide(0.0, 0.01, zone), Verdict::pass);
  EXPECT_EQ(decide(0.09, 0.01, zone), Verdict::pass);        // 0.09 + 0.01 is on the limit: inside
  EXPECT_EQ(decide(0.095, 0.01, zone), Verdict::undecided);  // the interval straddles 0.1
  EXPECT_EQ(decide(0.105, 0.01, zone), Verdict::undecided);
  EXPECT_EQ(decide(0.12, 0.01, zone), Verdict::fail);
  EXPECT_EQ(decide(-0.12, 0.01, zone), Verdict::fail);
  EXPECT_EQ(decide(-0.095, 0.01, zone), Verdict::undecided);
  EXPECT_EQ(decide(0.0, 0.2, zone), Verdict::undecided);  // an uncertainty wider than the zone proves nothing
  EXPECT_EQ(decide(std::nan(""), 0.01, zone), Verdict::undecided);
  EXPECT_EQ(worse(Verdict::pass, Verdict::fail), Verdict::fail);
}

TEST(Tolerances, PointOverridesCurveOverridesDefault) {
  Tolerances t;
  t.edge_profile_mm = 0.1;
  t.curve_profile_mm[3] = 0.05;
  t.edge_point_profile_mm[7] = 0.02;
  EXPECT_DOUBLE_EQ(t.edge_profile_for(1, 0), 0.1);
  EXPECT_DOUBLE_EQ(t.edge_profile_for(1, 3), 0.05);
  EXPECT_DOUBLE_EQ(t.edge_profile_for(7, 3), 0.02);
  t.hole_overrides[2].position_mm = 0.3;
  EXPECT_DOUBLE_EQ(t.hole_for(2).position_mm, 0.3);
  EXPECT_DOUBLE_EQ(t.hole_for(1).position_mm, t.hole.position_mm);
  EXPECT_NEAR(expanded_uncertainty(t, 0.002), 2 * std::hypot(0.002, 0.0015), 1e-15);
}

TEST(TolerancesJson, ReadsOverDefaultsAndWritesTheSameForm) {
  const nlohmann::json in = {{"edge_profile_mm", 0.05},
                             {"edge_points", {{"12", 0.02}}},
                             {"curves", {{"3", 0.04}}},
                             {"hole_diameter_mm", {-0.01, 0.03}},
                             {"holes", {{"1", {{"position_mm", 0.2}}}}}};
  description::JsonFields f(in);
  const Tolerances t = read_tolerances(f, Tolerances{});
  ASSERT_TRUE(f.ok());
  EXPECT_DOUBLE_EQ(t.edge_profile_mm, 0.05);
  EXPECT_DOUBLE_EQ(t.edge_point_profile_mm.at(12), 0.02);
  EXPECT_DOUBLE_EQ(t.curve_profile_mm.at(3), 0.04);
  EXPECT_EQ(t.hole.diameter, (ToleranceZone{-0.01, 0.03}));
  EXPECT_DOUBLE_EQ(t.hole_for(1).position_mm, 0.2);
  EXPECT_EQ(t.hole_for(1).diameter, t.hole.diameter);  // an override keeps what it does not name
  EXPECT_DOUBLE_EQ(t.coverage_factor, 2);              // the default
  description::JsonFields again(to_json(t));
  EXPECT_EQ(read_tolerances(again, Tolerances{}), t);
}

TEST(TolerancesJson, BadFieldsAreNamedByTheirPointers) {
  const nlohmann::json in = {{"edge_profile_mm", -1},
                             {"hole_diameter_mm", {0.05, -0.05}},
                             {"edge_points", {{"x", 0.1}}},
                             {"holes", {{"2", {{"diameter_mm", {0, 1, 2}}}}}},
                             {"colour", "red"}};
  description::JsonFields f(in, "/tolerances");
  (void)read_tolerances(f, Tolerances{});
  std::string all;
  try {
    f.throw_if_problems("job request");
  } catch (const description::FieldError& e) {
    for (const std::string& line : e.lines()) all += line + "\n";
  }
  EXPECT_NE(all.find("/tolerances/colour"), std::string::npos) << all;
  EXPECT_NE(all.find("/tolerances/edge_profile_mm"), std::string::npos) << all;
  EXPECT_NE(all.find("/tolerances/hole_diameter_mm: lower must not exceed upper"), std::string::npos) << all;
  EXPECT_NE(all.find("/tolerances/edge_points/x"), std::string::npos) << all;
  EXPECT_NE(all.find("/tolerances/holes/2/diameter_mm"), std::string::npos) << all;
}

// A measured edge point `offset_mm` outside the true edge of the part at sample s (along the bisector).
EdgeResult edge_at(int id, const geometry::TrueEdgeSample& s, double offset_mm) {
  EdgeResult e;
  e.id = id;
  e.status = FeatureStatus::measured;
  MeasuredPoint p;
  p.id = id;
  p.frame = PointFrame::scan;
  p.position = s.position + offset_mm * (s.n_up + s.n_down).normalized();
  p.sigma_mm = 0.001;
  e.scan = p;
  e.machine = p;
  e.reference = s.position;
  return e;
}

struct PlateScenario {
  geometry::AnalyticPart part = geometry::make_plate_with_holes({geometry::Tessellation::Style::cad, 1.0, 0.0005});
  MeasurementResult result;
  Tolerances tolerances;

  PlateScenario() {
    tolerances.edge_profile_mm = 0.05;
    tolerances.machine_uncertainty_mm = 0.0015;
    const std::vector<double> offsets = {0.0, 0.03, -0.048, 0.06, -0.2};
    for (std::size_t i = 0; i < offsets.size(); ++i) {
      const geometry::TrueEdge& edge = part.sharp_edges[0];
      result.edges.push_back(edge_at(static_cast<int>(i), edge.samples[edge.samples.size() * (i + 1) / 8], offsets[i]));
    }
    EdgeResult missing;
    missing.id = 5;
    missing.status = FeatureStatus::failed;
    missing.reason = "touch 11 missed";
    result.edges.push_back(missing);
    const geometry::TrueHole& h = part.holes.at(0);
    HoleResult hole;
    hole.id = 0;
    // The reference's rim, as a scan put it: 0.1 mm off the true one.
    hole.nominal_centre = h.centre + Vec3(0.1, 0, 0.05);
    hole.nominal_axis = h.axis;
    hole.nominal_diameter_mm = 2 * h.radius - 0.1;
    hole.status = FeatureStatus::measured;
    BoreMeasurement bore;
    bore.centre = h.centre - 0.5 * h.axis + Vec3(0.004, 0.003, 0) ;  // 5 µm off the axis, half way down
    bore.axis = h.axis;
    bore.diameter_mm = 2 * h.radius + 0.02;
    bore.centre_sigma_mm = bore.diameter_sigma_mm = 0.001;
    hole.scan = bore;
    hole.machine = bore;
    result.holes.push_back(hole);
  }
};

TEST(Inspect, EdgesAndHolesOfACadExportAgainstKnownOffsets) {
  PlateScenario s;
  ASSERT_GT(s.part.mesh.faces.rows(), 0);
  const NominalModel nominal = nominal_model(s.part.mesh, Eigen::Isometry3d::Identity(), 30);
  ASSERT_FALSE(nominal.edges.empty());
  const InspectionResult r = inspect(s.result, {}, nominal, s.tolerances, {});
  ASSERT_EQ(r.edges.size(), 6u);
  const std::vector<double> expected = {0.0, 0.03, -0.048, 0.06, -0.2};
  const std::vector<Verdict> verdicts = {Verdict::pass, Verdict::pass, Verdict::undecided, Verdict::fail, Verdict::fail};
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_NEAR(r.edges[i].profile.deviation_mm, expected[i], 1e-6) << "edge point " << i;
    EXPECT_EQ(r.edges[i].profile.verdict, verdicts[i]) << "edge point " << i;
    ASSERT_TRUE(r.edges[i].nominal_S);
  }
  EXPECT_EQ(r.edges[5].profile.verdict, Verdict::not_measured);
  EXPECT_EQ(r.edges[5].reason, "touch 11 missed");
  EXPECT_EQ(r.edge_counts.pass, 2);
  EXPECT_EQ(r.edge_counts.fail, 2);
  EXPECT_EQ(r.edge_counts.undecided, 1);
  EXPECT_EQ(r.edge_counts.not_measured, 1);

  const HoleInspection& hole = r.holes.at(0);
  EXPECT_NEAR(hole.diameter.deviation_mm, 0.02, 1e-3);  // the CAD rim's chords: 0.5 µm
  EXPECT_NEAR(hole.position.deviation_mm, 0.010, 1e-3);
  EXPECT_EQ(hole.diameter.verdict, Verdict::pass);  // 0.02 + 2·√(1² + 1.5²) µm inside ±0.05
  EXPECT_EQ(hole.position.verdict, Verdict::pass);
  EXPECT_EQ(r.hole_counts.pass, 1);
  EXPECT_EQ(r.verdict, Verdict::fail);
}

TEST(Inspect, OneToleranceChangedMakesTheFeatureFailEverywhere) {
  PlateScenario s;
  s.tolerances.hole.diameter = {-0.01, 0.01};
  const NominalModel nominal = nominal_model(s.part.mesh, Eigen::Isometry3d::Identity(), 30);
  s.result.edges.resize(2);  // the passing ones
  s.result.inspection = inspect(s.result, {}, nominal, s.tolerances, {});
  EXPECT_EQ(s.result.inspection->holes[0].diameter.verdict, Verdict::fail);
  EXPECT_EQ(s.result.inspection->verdict, Verdict::fail);
  const nlohmann::json j = to_json(s.result);
  EXPECT_EQ(j["inspection"]["verdict"], "fail");
  EXPECT_EQ(j["holes"][0]["inspection"]["diameter"]["verdict"], "fail");
  EXPECT_EQ(j["holes"][0]["inspection"]["position"]["verdict"], "pass");
  EXPECT_EQ(j["edge_points"][0]["inspection"]["verdict"], "pass");
  const std::string csv = holes_to_csv(s.result);
  EXPECT_NE(csv.find(",fail,"), std::string::npos) << csv;
  EXPECT_NE(to_csv(s.result).find(",pass,"), std::string::npos);

  s.tolerances.hole.diameter = {-0.05, 0.05};
  s.result.inspection = inspect(s.result, {}, nominal, s.tolerances, {});
  EXPECT_EQ(s.result.inspection->verdict, Verdict::pass);
}

TEST(Inspect, AFarPointHasNoNominalEdgeAndIsNotJudged) {
  PlateScenario s;
  s.result.edges.resize(1);
  s.result.edges[0].scan->position += Vec3(0, 0, 50);
  s.result.holes.clear();
  const NominalModel nominal = nominal_model(s.part.mesh, Eigen::Isometry3d::Identity(), 30);
  const InspectionResult r = inspect(s.result, {}, nominal, s.tolerances, {});
  EXPECT_EQ(r.edges[0].profile.verdict, Verdict::not_measured);
  EXPECT_NE(r.edges[0].reason.find("no sharp edge of the nominal within"), std::string::npos);
  EXPECT_EQ(r.verdict, Verdict::incomplete) << "nothing judged is no pass";
}

// The passing scenario with one edge point's touch missed: the job was asked for it and has no
// measurement, so it is incomplete, not pass; the same job with that point left out on purpose passes,
// and counts it apart with its reason. Everywhere the verdict is written says the same.
TEST(Inspect, AnUnmeasuredFeatureMakesTheJobIncompleteUnlessLeftOutOnPurpose) {
  PlateScenario s;
  const NominalModel nominal = nominal_model(s.part.mesh, Eigen::Isometry3d::Identity(), 30);
  s.result.edges.erase(s.result.edges.begin() + 2, s.result.edges.begin() + 5);  // keep 0, 1 (pass) and 5 (missed)
  s.result.inspection = inspect(s.result, {}, nominal, s.tolerances, {});
  const InspectionResult& asked = *s.result.inspection;
  EXPECT_EQ(asked.verdict, Verdict::incomplete);
  EXPECT_EQ(asked.edge_counts.pass, 2);
  EXPECT_EQ(asked.edge_counts.not_measured, 1);
  EXPECT_EQ(asked.edge_counts.excluded, 0);
  EXPECT_EQ(coverage_text(asked), "2 of 3 inspected edge points measured (1 not measured), 1 of 1 inspected holes measured");
  nlohmann::json j = to_json(s.result);
  EXPECT_EQ(j["inspection"]["verdict"], "incomplete");
  EXPECT_EQ(j["inspection"]["counts"]["edge_points"]["not_measured"], 1);
  EXPECT_EQ(j["edge_points"][2]["inspection"]["verdict"], "not_measured");

  InspectionScope scope;
  scope.excluded_edge_points = {5};
  scope.exclude_reason = "under the clamp";
  s.result.inspection = inspect(s.result, {}, nominal, s.tolerances, {}, scope);
  const InspectionResult& left_out = *s.result.inspection;
  EXPECT_EQ(left_out.verdict, Verdict::pass);
  EXPECT_EQ(left_out.edge_counts.not_measured, 0);
  EXPECT_EQ(left_out.edge_counts.excluded, 1);
  EXPECT_EQ(left_out.edges[2].profile.verdict, Verdict::excluded);
  EXPECT_EQ(left_out.edges[2].reason, "under the clamp");
  ASSERT_EQ(left_out.exclusions.size(), 1u);
  EXPECT_EQ(left_out.exclusions[0].edge_points, 1);
  EXPECT_EQ(coverage_text(left_out),
            "2 of 2 inspected edge points measured, 1 of 1 inspected holes measured; 1 edge point excluded (under the clamp)");
  j = to_json(s.result);
  EXPECT_EQ(j["inspection"]["verdict"], "pass");
  EXPECT_EQ(j["inspection"]["counts"]["edge_points"]["not_measured"], 0) << "a pass carries no not_measured";
  EXPECT_EQ(j["inspection"]["counts"]["edge_points"]["excluded"], 1);
  EXPECT_EQ(j["inspection"]["exclusions"][0]["reason"], "under the clamp");
  EXPECT_EQ(j["inspection"]["inspect"]["exclude"]["edge_points"], nlohmann::json::array({5}));
  EXPECT_EQ(j["edge_points"][2]["inspection"]["verdict"], "excluded");
  EXPECT_TRUE(j["edge_points"][2]["inspection"]["deviation_mm"].is_null());
  EXPECT_NE(to_csv(s.result).find(",excluded,"), std::string::npos);
}

// "not_probeable" leaves out what the plan could not measure in this set-up, with the plan's reason;
// a feature the plan measured and whose touch then failed stays asked for.
TEST(Inspect, NotProbeableFeaturesAreExcludedWithThePlansReasonFailedOnesAreNot) {
  PlateScenario s;
  const NominalModel nominal = nominal_model(s.part.mesh, Eigen::Isometry3d::Identity(), 30);
  s.result.edges.resize(2);
  EdgeResult on_plate;
  on_plate.id = 2;
  on_plate.status = FeatureStatus::not_planned;
  on_plate.reason = "open boundary: the mesh has no surface beyond it";
  s.result.edges.push_back(on_plate);
  HoleResult blocked;
  blocked.id = 1;
  blocked.reason = "bore touch 0 is out of reach";
  s.result.holes.push_back(blocked);
  InspectionScope scope;
  EXPECT_EQ(inspect(s.result, {}, nominal, s.tolerances, {}, scope).verdict, Verdict::incomplete);
  scope.exclude_not_probeable = true;
  InspectionResult r = inspect(s.result, {}, nominal, s.tolerances, {}, scope);
  EXPECT_EQ(r.verdict, Verdict::pass);
  EXPECT_EQ(r.edges[2].reason, std::string(kNotProbeable) + ": open boundary: the mesh has no surface beyond it");
  EXPECT_EQ(r.holes[1].diameter.verdict, Verdict::excluded);
  EXPECT_EQ(r.hole_counts.excluded, 1);
  EXPECT_EQ(coverage_text(r), "2 of 2 inspected edge points measured, 1 of 1 inspected holes measured; 1 edge point and "
                              "1 hole excluded (not probeable in this set-up)");

  s.result.edges[1].status = FeatureStatus::failed;  // planned, touched, refused: still asked for
  s.result.edges[1].scan.reset();
  r = inspect(s.result, {}, nominal, s.tolerances, {}, scope);
  EXPECT_EQ(r.verdict, Verdict::incomplete);
  EXPECT_EQ(r.edge_counts.not_measured, 1);
}

// Asking for some features only: the rest are excluded as not asked for; a curve asks for its points;
// an id the model does not have is noted, never silently dropped.
TEST(Inspect, AChosenScopeExcludesTheRestAsNotAskedFor) {
  PlateScenario s;
  const NominalModel nominal = nominal_model(s.part.mesh, Eigen::Isometry3d::Identity(), 30);
  std::vector<geometry::EdgePoint> reference(6);
  for (int i = 0; i < 6; ++i) reference[static_cast<std::size_t>(i)].curve = i < 2 ? 7 : 8;
  InspectionScope scope;
  scope.edge_points = std::set<int>{};
  scope.curves = {7};
  scope.holes = std::set<int>{0, 9};
  const InspectionResult r = inspect(s.result, reference, nominal, s.tolerances, {}, scope);
  EXPECT_EQ(r.edge_counts.pass, 2);
  EXPECT_EQ(r.edge_counts.excluded, 4);
  EXPECT_EQ(r.edges[5].reason, kNotAskedFor);
  EXPECT_EQ(r.hole_counts.pass, 1);
  EXPECT_EQ(r.verdict, Verdict::pass);
  ASSERT_EQ(r.notes.size(), 1u);
  EXPECT_EQ(r.notes[0], "inspect: the model has no hole 9");

  InspectionScope nothing;
  nothing.edge_points = std::set<int>{};
  nothing.holes = std::set<int>{};
  EXPECT_EQ(inspect(s.result, reference, nominal, s.tolerances, {}, nothing).verdict, Verdict::incomplete)
      << "a job asked to inspect nothing has inspected nothing";
}

TEST(Inspect, WithoutANominalTheResultHasNoInspection) {
  PlateScenario s;
  const nlohmann::json j = to_json(s.result);
  EXPECT_TRUE(j["inspection"].is_null());
  EXPECT_TRUE(j["edge_points"][0]["inspection"].is_null());
  const std::string header = to_csv(s.result).substr(0, to_csv(s.result).find('\n'));
  EXPECT_NE(header.find("nominal_deviation_mm,uncertainty_mm,tolerance_lower_mm,tolerance_upper_mm,verdict,reason"),
            std::string::npos);
}

}  // namespace
}  // namespace cmm::planner
