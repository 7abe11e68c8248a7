// DMIS export: golden files byte for byte (CMMD_REGENERATE_GOLDEN=1 rewrites them), the strict
// checker on them and on one mutation per rule, the PTMEAS sign convention, and the refusals.
#include <unistd.h>

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "dmis_checker.hpp"
#include "geometry/file_error.hpp"
#include "planner/dmis_export.hpp"

namespace {

namespace fs = std::filesystem;
using namespace cmm::planner;
namespace description = cmm::description;
using cmm::geometry::Hole;
using cmm::planner::testing::check_dmis;
using cmm::planner::testing::DmisCheckOptions;
using cmm::planner::testing::DmisCheckResult;

constexpr double ball_radius = 1.0;

description::MachineDescription test_machine() {
  description::MachineDescription m;
  m.travel_box = {Vec3(-50, -50, -20), Vec3(400, 300, 150)};
  m.max_speed_mm_s = 100;
  m.probe_speed_mm_s = 5;
  m.clearance_z = 60;
  description::StylusTip tip;
  tip.id = "T1";
  tip.ball_radius_mm = ball_radius;
  tip.offset = Vec3(0, 0, -30);
  tip.direction = -Vec3::UnitZ();
  m.tips = {tip};
  m.active_tip = "T1";
  return m;
}

// A touch as the planner makes it: the ball centre line through the surface point along d, the
// search starting `approach` before the nominal contact and ending `search` past it.
Touch make_touch(int id, TouchTarget target, const Vec3& surface, const Vec3& direction, double approach = 3,
                 double search = 2, double retract = 2) {
  Touch t;
  t.id = id;
  t.target = target;
  t.surface_point = surface;
  t.direction = direction.normalized();
  t.nominal_centre = surface - ball_radius * t.direction;
  t.start = t.nominal_centre - approach * t.direction;
  t.max_travel_mm = approach + search;
  t.retract_mm = retract;
  return t;
}

// The two touches of a convex edge point: axis ± β in the cross-section plane, both through A.
std::pair<Touch, Touch> edge_touches(int first_id, int edge_point, const Vec3& a, const Vec3& n_up, const Vec3& n_down,
                                     double beta_rad) {
  const Vec3 tangent = n_up.cross(n_down).normalized();
  const Vec3 axis = -(n_up + n_down).normalized();
  Touch t1 = make_touch(first_id, TouchTarget::edge, a, Eigen::AngleAxisd(beta_rad, tangent) * axis);
  Touch t2 = make_touch(first_id + 1, TouchTarget::edge, a, Eigen::AngleAxisd(-beta_rad, tangent) * axis);
  t1.edge_point = t2.edge_point = edge_point;
  t1.face = 0;
  t2.face = 1;
  return {t1, t2};
}

Hole bore_hole() {
  Hole h;
  h.id = 3;
  h.centre = Vec3(100, 80, 40);
  h.axis = Vec3::UnitZ();
  h.radius = 5;
  return h;
}

// The hand-built program of the golden file, on a block 0..150 × 0..200 × 0..40 with a step down to
// z = 20 beyond y = 150: convex edge points 12 (top/front) and 7 (top/right), whose second touch
// comes after a face touch in machine order; concave edge point 5 at the step's foot, a touch on
// its floor (straight down) and one on its wall; bore 3 (Ø10) touched six times 5 mm down.
// A program of `touches` in the order given, with its motions (what the DMIS export writes).
MoveProgram sequenced(const MoveProgram& p) {
  return program_in_order(p.touches, test_machine(), p.home, p.clearance_z);
}

MoveProgram hand_program() {
  MoveProgram p;
  p.home = Vec3(0, 0, 60);
  p.clearance_z = 60;
  const double beta = 30 * std::numbers::pi / 180;
  auto [e12a, e12b] = edge_touches(1, 12, Vec3(50, 0, 40), Vec3::UnitZ(), -Vec3::UnitY(), beta);
  auto [e7a, e7b] = edge_touches(3, 7, Vec3(150, 60, 40), Vec3::UnitZ(), Vec3::UnitX(), beta);
  e7b.id = 5;
  Touch floor = make_touch(4, TouchTarget::face, Vec3(60, 153, 20), -Vec3::UnitZ());
  Touch wall = make_touch(6, TouchTarget::face, Vec3(60, 150, 23), -Vec3::UnitY());
  floor.edge_point = wall.edge_point = 5;
  floor.face = 0;
  wall.face = 1;
  p.touches = {e12a, e12b, e7a, e7b, floor, wall};
  const Hole h = bore_hole();
  for (int k = 0; k < 6; ++k) {
    const double angle = k * std::numbers::pi / 3;
    const Vec3 radial(std::cos(angle), std::sin(angle), 0);
    Touch t = make_touch(7 + k, TouchTarget::bore, h.centre + h.radius * radial - 5 * h.axis, radial);
    t.hole = h.id;
    t.face = k;
    p.touches.push_back(t);
  }
  return sequenced(p);
}

// Registration touches: faces 0 (top, twice), 1 (front) and 2 (left) at plate corner 1 and the
// fiducial; the second top touch is searched from farther away, so an SNSET changes inside a block.
MoveProgram registration_program() {
  MoveProgram p;
  p.home = Vec3(0, 0, 60);
  p.clearance_z = 60;
  Touch top = make_touch(20, TouchTarget::plate_face, Vec3(5, 5, 10), -Vec3::UnitZ());
  Touch front = make_touch(21, TouchTarget::plate_face, Vec3(5, 0, 5), Vec3::UnitY());
  Touch top2 = make_touch(22, TouchTarget::plate_face, Vec3(8, 8, 10), -Vec3::UnitZ(), 5, 3, 2);
  Touch left = make_touch(23, TouchTarget::plate_face, Vec3(0, 5, 5), Vec3::UnitX());
  top.corner = front.corner = top2.corner = left.corner = 1;
  top.face = top2.face = 0;
  front.face = 1;
  left.face = 2;
  Touch fiducial = make_touch(24, TouchTarget::fiducial, Vec3(30, 20, 12), -Vec3::UnitZ());
  p.touches = {top, top2, front, left, fiducial};
  return sequenced(p);
}

std::string dmis_of(const MoveProgram& program, const std::vector<DmisFeature>& features,
                    const description::MachineDescription& machine = test_machine()) {
  std::ostringstream out;
  write_dmis(out, program, machine, features, {"cmmd test program", "hand block"});
  return out.str();
}

std::string read_text(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::string join(const std::vector<std::string>& lines) {
  std::string text;
  for (const std::string& l : lines) text += l + '\n';
  return text;
}

// 1-based number of the first line that starts with `prefix` (0 when none).
std::size_t line_starting(const std::vector<std::string>& lines, const std::string& prefix, std::size_t from = 1) {
  for (std::size_t i = from - 1; i < lines.size(); ++i)
    if (lines[i].rfind(prefix, 0) == 0) return i + 1;
  return 0;
}

// Compares with the golden file, or rewrites it when CMMD_REGENERATE_GOLDEN is set (see docs/dmis.md).
void expect_golden(const std::string& text, const std::string& name) {
  const fs::path file = fs::path(CMMD_TEST_DATA_DIR) / "dmis" / name;
  if (const char* regenerate = std::getenv("CMMD_REGENERATE_GOLDEN"); regenerate && *regenerate) {
    fs::create_directories(file.parent_path());
    std::ofstream(file, std::ios::binary) << text;
    std::cout << "regenerated " << file << '\n';
    return;
  }
  ASSERT_TRUE(fs::exists(file)) << file << " is missing; run with CMMD_REGENERATE_GOLDEN=1";
  const std::string golden = read_text(file);
  if (golden == text) return;
  const auto want = lines_of(golden), got = lines_of(text);
  for (std::size_t i = 0; i < std::max(want.size(), got.size()); ++i) {
    const std::string w = i < want.size() ? want[i] : "<end>", g = i < got.size() ? got[i] : "<end>";
    if (w != g) {
      ADD_FAILURE() << name << " differs at line " << i + 1 << "\n  golden: " << w << "\n  now:    " << g;
      return;
    }
  }
  ADD_FAILURE() << name << " differs in its line ends";
}

DmisCheckOptions full_check(const MoveProgram& program) {
  DmisCheckOptions options;
  options.travel_box = test_machine().travel_box;
  options.program = &program;
  return options;
}

TEST(DmisExport, HandProgramMatchesGolden) {
  const MoveProgram program = hand_program();
  expect_golden(dmis_of(program, dmis_features(program, {bore_hole()})), "hand_program.dmi");
}

TEST(DmisExport, RegistrationProgramMatchesGolden) {
  const MoveProgram program = registration_program();
  expect_golden(dmis_of(program, dmis_features(program)), "registration.dmi");
}

TEST(DmisExport, CheckerAcceptsTheGoldenFiles) {
  const MoveProgram hand = hand_program(), registration = registration_program();
  const fs::path dir = fs::path(CMMD_TEST_DATA_DIR) / "dmis";
  EXPECT_TRUE(check_dmis(read_text(dir / "hand_program.dmi"), full_check(hand)).ok())
      << check_dmis(read_text(dir / "hand_program.dmi"), full_check(hand));
  EXPECT_TRUE(check_dmis(read_text(dir / "registration.dmi"), full_check(registration)).ok())
      << check_dmis(read_text(dir / "registration.dmi"), full_check(registration));
}

TEST(DmisExport, FeaturesInProgramOrderEachInOneBlock) {
  const MoveProgram program = hand_program();
  const auto features = dmis_features(program, {bore_hole()});
  ASSERT_EQ(features.size(), 5u);
  const std::vector<std::string> labels = {"EDGE_12", "EDGE_7", "FACE_5_0", "FACE_5_1", "BORE_3"};
  for (std::size_t i = 0; i < labels.size(); ++i) EXPECT_EQ(features[i].label, labels[i]);
  EXPECT_EQ(features[1].touch_ids, (std::vector<int>{3, 5}));
  const auto lines = lines_of(dmis_of(program, features));
  const std::size_t meas = line_starting(lines, "MEAS/POINT,F(EDGE_7),2");
  const std::size_t end = line_starting(lines, "ENDMES", meas);
  ASSERT_GT(meas, 0u);
  int ptmeas = 0;
  for (std::size_t i = meas; i < end; ++i) ptmeas += lines[i - 1].rfind("PTMEAS/", 0) == 0;
  EXPECT_EQ(ptmeas, 2);
  EXPECT_LT(end, line_starting(lines, "F(FACE_5_0)="));

  // A program that makes a feature's touches with another's between them cannot be written as it
  // runs (a MEAS block holds all of its feature's touches): refused, nothing written.
  MoveProgram interleaved = program;
  std::swap(interleaved.touches[3], interleaved.touches[4]);  // EDGE_7, FACE_5_0, EDGE_7
  interleaved = sequenced(interleaved);
  std::ostringstream out;
  try {
    write_dmis(out, interleaved, test_machine(), dmis_features(interleaved, {bore_hole()}));
    ADD_FAILURE() << "an interleaved program was written";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("EDGE_7: its touches are not one after the other"), std::string::npos)
        << e.what();
  }
  EXPECT_TRUE(out.str().empty());
}

TEST(DmisExport, TheGotosAreTheProgramsMoves) {
  const MoveProgram program = hand_program();
  const auto lines = lines_of(dmis_of(program, dmis_features(program, {bore_hole()})));
  std::vector<std::string> gotos;
  for (const std::string& line : lines)
    if (line.rfind("GOTO/", 0) == 0) gotos.push_back(line.substr(5));
  std::vector<std::string> moves = {"0.0000,0.0000,60.0000"};  // home first: the DME starts anywhere
  for (const Motion& m : program.motions) {
    char text[96];
    std::snprintf(text, sizeof text, "%.4f,%.4f,%.4f", m.to.x(), m.to.y(), m.to.z());
    // A probe's search and retract are the PTMEAS; a return to where the retract already left the
    // ball prints as no move.
    if (m.kind == MotionKind::probe) moves.push_back("(probe)");
    else moves.emplace_back(text);
  }
  std::vector<std::string> expected;
  std::string at = moves.front();
  expected.push_back(at);
  for (std::size_t i = 1; i < moves.size(); ++i) {
    if (moves[i] == "(probe)") {
      const Motion& probe = program.motions[i - 1];
      char text[96];
      std::snprintf(text, sizeof text, "%.4f,%.4f,%.4f", probe.to.x(), probe.to.y(), probe.to.z());
      at = text;
      continue;
    }
    if (moves[i] != at) expected.push_back(moves[i]);
    at = moves[i];
  }
  EXPECT_EQ(gotos, expected);
}

TEST(DmisExport, EdgeFeatureNormalIsTheWindowAxisReversed) {
  const auto features = dmis_features(hand_program(), {bore_hole()});
  // Top/front edge: outward bisector of (0,0,1) and (0,-1,0).
  EXPECT_LT((features[0].ijk - Vec3(0, -1, 1).normalized()).norm(), 1e-12);
  EXPECT_LT((features[0].nominal - Vec3(50, 0, 40)).norm(), 1e-12);
}

TEST(DmisExport, BoreFittedFromTouchesEqualsTheHolesNominal) {
  const MoveProgram program = hand_program();
  const auto from_hole = dmis_features(program, {bore_hole()});
  const auto fitted = dmis_features(program);
  EXPECT_LT((fitted[4].nominal - Vec3(100, 80, 35)).norm(), 1e-9);
  EXPECT_LT((fitted[4].ijk - Vec3::UnitZ()).norm(), 1e-9);
  EXPECT_NEAR(fitted[4].diameter_mm, 10, 1e-9);
  EXPECT_TRUE(fitted[4].inner);
  EXPECT_EQ(dmis_of(program, fitted), dmis_of(program, from_hole));
}

TEST(DmisExport, BossTouchedFromOutsideIsOuter) {
  MoveProgram p;
  p.clearance_z = 60;
  for (int k = 0; k < 4; ++k) {
    const Vec3 radial(std::cos(k * std::numbers::pi / 2), std::sin(k * std::numbers::pi / 2), 0);
    Touch t = make_touch(k, TouchTarget::bore, Vec3(10, 10, 5) + 4 * radial, -radial);
    t.hole = 1;
    p.touches.push_back(t);
  }
  p = sequenced(p);
  const auto features = dmis_features(p);
  ASSERT_EQ(features.size(), 1u);
  EXPECT_FALSE(features[0].inner);
  EXPECT_NEAR(features[0].diameter_mm, 8, 1e-9);
  EXPECT_NE(dmis_of(p, features).find("FEAT/CIRCLE,OUTER,CART,10.0000,10.0000,5.0000,0.000000,0.000000,1.000000,8.0000"),
            std::string::npos);
  p.touches.resize(2);
  EXPECT_THROW(dmis_features(p), std::invalid_argument);  // two touches span no circle
}

// The one sign that matters: DMIS ijk points out of the material, the planner's direction into it.
TEST(DmisExport, PtmeasIjkIsMinusTheApproachDirection) {
  MoveProgram p;
  p.home = Vec3(0, 0, 60);
  p.clearance_z = 60;
  Touch down = make_touch(1, TouchTarget::face, Vec3(10, 20, 5), -Vec3::UnitZ());
  down.edge_point = 4;
  p.touches = {down};
  p = sequenced(p);
  const std::string text = dmis_of(p, dmis_features(p));
  // xyz is the surface point, not the ball centre (10, 20, 6).
  EXPECT_NE(text.find("\nPTMEAS/CART,10.0000,20.0000,5.0000,0.000000,0.000000,1.000000\n"), std::string::npos) << text;
  EXPECT_NE(text.find("\nF(FACE_4_0)=FEAT/POINT,CART,10.0000,20.0000,5.0000,0.000000,0.000000,1.000000\n"),
            std::string::npos);
  EXPECT_NE(text.find("\nGOTO/10.0000,20.0000,9.0000\nPTMEAS/"), std::string::npos);  // start: 3 mm above the contact
  EXPECT_TRUE(check_dmis(text, full_check(p)).ok()) << check_dmis(text, full_check(p));

  // The same file with the sign flipped is caught, on the PTMEAS line.
  auto lines = lines_of(text);
  const std::size_t at = line_starting(lines, "PTMEAS/");
  lines[at - 1] = "PTMEAS/CART,10.0000,20.0000,5.0000,0.000000,0.000000,-1.000000";
  const DmisCheckResult r = check_dmis(join(lines), full_check(p));
  EXPECT_EQ(r.line, at);
  EXPECT_NE(r.message.find("not -(approach direction) of touch 1"), std::string::npos) << r;
}

// The travel box holds ball centres: a bore's PTMEAS surface point lies outside a box its ball
// centre (1 mm toward the axis) is inside.
TEST(DmisChecker, TravelBoxIsCheckedOnTheBallCentre) {
  MoveProgram bore = hand_program();
  bore.touches.erase(bore.touches.begin(), bore.touches.begin() + 6);
  bore = sequenced(bore);
  const std::string text = dmis_of(bore, dmis_features(bore, {bore_hole()}));
  DmisCheckOptions options;
  options.travel_box = description::TravelBox{Vec3(-1, -1, 0), Vec3(104.5, 200, 100)};  // surface point x = 105, centre 104
  EXPECT_TRUE(check_dmis(text, options).ok()) << check_dmis(text, options);
  options.travel_box->max.x() = 103.9;
  const DmisCheckResult r = check_dmis(text, options);
  EXPECT_EQ(r.line, line_starting(lines_of(text), "PTMEAS/CART,105.0000"));
  EXPECT_EQ(r.message, "PTMEAS ball centre (104.0000,80.0000,35.0000) outside the travel box");
}

struct Mutation {
  std::string rule;
  // Edits the golden lines and returns the line the checker must stop at.
  std::function<std::size_t(std::vector<std::string>&)> apply;
  std::string message;  // a part of the expected message
  bool with_program = true;
};

std::size_t replace_line(std::vector<std::string>& lines, const std::string& prefix, const std::string& with,
                         std::size_t from = 1) {
  const std::size_t at = line_starting(lines, prefix, from);
  if (at == 0) throw std::logic_error("no line starts with " + prefix);
  lines[at - 1] = with;
  return at;
}

std::size_t erase_line(std::vector<std::string>& lines, const std::string& prefix) {
  const std::size_t at = line_starting(lines, prefix);
  if (at == 0) throw std::logic_error("no line starts with " + prefix);
  lines.erase(lines.begin() + static_cast<std::ptrdiff_t>(at - 1));
  return at;
}

std::vector<Mutation> mutations() {
  const std::string edge12 = "F(EDGE_12)=FEAT/POINT,CART,50.0000,0.0000,40.0000,0.000000,-0.707107,0.707107";
  return {
      {"unknown statement",
       [](auto& l) {
         l.insert(l.begin() + 4, "TOL/DIAM,0.0100");
         return std::size_t{5};
       },
       "unknown statement 'TOL'"},
      {"DMISMN first",
       [](auto& l) {
         std::swap(l[0], l[1]);
         return std::size_t{1};
       },
       "the file must open with DMISMN"},
      {"FILNAM after DMISMN",
       [](auto& l) {
         std::swap(l[1], l[3]);  // UNITS, then FILNAM
         return std::size_t{2};
       },
       "FILNAM must follow DMISMN"},
      {"ENDFIL last",
       [](auto& l) {
         l.push_back("GOTO/0.0000,0.0000,60.0000");
         return l.size();
       },
       "statement after ENDFIL"},
      {"ENDFIL present",
       [](auto& l) {
         l.pop_back();
         return l.size();
       },
       "missing ENDFIL"},
      {"UNITS before coordinates",
       [](auto& l) {
         const std::size_t units = line_starting(l, "UNITS/");
         const std::string line = l[units - 1];
         l.erase(l.begin() + static_cast<std::ptrdiff_t>(units - 1));
         const std::size_t sensor = line_starting(l, "S(T1)=SNSDEF/");
         l.insert(l.begin() + static_cast<std::ptrdiff_t>(sensor), line);
         return sensor;
       },
       "SNSDEF before UNITS"},
      {"SNSDEF before SNSLCT",
       [](auto& l) {
         const std::size_t def = line_starting(l, "S(T1)=SNSDEF/");
         std::swap(l[def - 1], l[def]);
         return def;
       },
       "SNSLCT/S(T1) before its SNSDEF"},
      {"SNSLCT before motion",
       [](auto& l) {
         erase_line(l, "SNSLCT/");
         return line_starting(l, "GOTO/");
       },
       "GOTO before SNSLCT"},
      {"MODE before motion",
       [](auto& l) {
         erase_line(l, "MODE/");
         return line_starting(l, "GOTO/");
       },
       "GOTO before MODE/PROG,MAN"},
      {"FEAT before MEAS",
       [edge12](auto& l) { return erase_line(l, edge12); },
       "MEAS of F(EDGE_12), which no FEAT defines before it"},
      {"PTMEAS count",
       [](auto& l) {
         replace_line(l, "MEAS/POINT,F(EDGE_12),2", "MEAS/POINT,F(EDGE_12),3");
         return line_starting(l, "ENDMES");
       },
       "announces 3 PTMEAS, has 2"},
      {"PTMEAS count exceeded",
       [](auto& l) {
         const std::size_t meas = replace_line(l, "MEAS/POINT,F(EDGE_12),2", "MEAS/POINT,F(EDGE_12),1");
         return line_starting(l, "PTMEAS/", line_starting(l, "PTMEAS/", meas) + 1);
       },
       "announces 1 PTMEAS, this is one more"},
      {"ijk unit",
       [](auto& l) {
         return replace_line(l, "F(FACE_5_0)=", "F(FACE_5_0)=FEAT/POINT,CART,60.0000,153.0000,20.0000,0.000000,0.000000,0.999990");
       },
       "ijk is not a unit vector (length 0.999990000)"},
      {"numeric syntax",
       [](auto& l) { return replace_line(l, "GOTO/0.0000,0.0000,60.0000", "GOTO/0.0000,0.0000,6E1"); },
       "bad number '6E1'"},
      {"numeric syntax: decimals",
       [](auto& l) { return replace_line(l, "GOTO/0.0000,0.0000,60.0000", "GOTO/0.0000,0.0000,60.0"); },
       "bad number '60.0'"},
      {"duplicate label",
       [](auto& l) {
         return replace_line(l, "F(EDGE_7)=FEAT/POINT", "F(EDGE_12)=FEAT/POINT,CART,150.0000,60.0000,40.0000,0.707107,0.000000,0.707107");
       },
       "duplicate label F(EDGE_12)"},
      {"GOTO in the travel box",
       [](auto& l) { return replace_line(l, "GOTO/0.0000,0.0000,60.0000", "GOTO/0.0000,0.0000,160.0000"); },
       "GOTO (0.0000,0.0000,160.0000) outside the travel box"},
      {"PTMEAS is a touch of the program",
       [](auto& l) {
         return replace_line(l, "PTMEAS/CART,60.0000,153.0000", "PTMEAS/CART,60.0000,153.5000,20.0000,0.000000,0.000000,1.000000");
       },
       "PTMEAS at (60.0000,153.5000,20.0000) is no touch of the program"},
      {"PTMEAS ijk = -direction",
       [](auto& l) {
         return replace_line(l, "PTMEAS/CART,60.0000,150.0000", "PTMEAS/CART,60.0000,150.0000,23.0000,0.000000,-1.000000,0.000000");
       },
       "PTMEAS ijk is not -(approach direction) of touch 6: expected (0.000000,1.000000,0.000000)"},
      {"PTMEAS from the approach start",
       [](auto& l) {
         const std::size_t at = line_starting(l, "PTMEAS/CART,60.0000,150.0000");
         l[at - 2] = "GOTO/60.0000,155.0000,23.0000";
         return at;
       },
       "PTMEAS of touch 6 not reached from its approach start (60.0000,154.0000,23.0000)"},
      {"SNSET/APPRCH matches the plan",
       [](auto& l) {
         replace_line(l, "SNSET/APPRCH,", "SNSET/APPRCH,2.5000");
         return line_starting(l, "PTMEAS/");
       },
       "SNSET/APPRCH does not match the approach of touch 1"},
      {"every touch measured",
       [](auto& l) {
         const std::size_t meas = replace_line(l, "MEAS/CIRCLE,F(BORE_3),6", "MEAS/CIRCLE,F(BORE_3),5");
         std::size_t sixth = meas;
         for (int k = 0; k < 6; ++k) sixth = line_starting(l, "PTMEAS/", sixth + 1);
         std::size_t first = sixth;  // the sixth PTMEAS and the GOTOs that lead to it go
         while (l[first - 2].rfind("GOTO/", 0) == 0) --first;
         l.erase(l.begin() + static_cast<std::ptrdiff_t>(first - 1), l.begin() + static_cast<std::ptrdiff_t>(sixth));
         return line_starting(l, "ENDFIL");
       },
       "touch 12 is never measured"},
      {"MEAS block closed",
       [](auto& l) {
         const std::size_t end = line_starting(l, "ENDMES");
         l.erase(l.begin() + static_cast<std::ptrdiff_t>(end - 1));
         return line_starting(l, "F(EDGE_7)=");
       },
       "FEAT inside the MEAS block of F(EDGE_12) (ENDMES missing)"},
      {"PTMEAS inside a block",
       [](auto& l) {
         const std::size_t meas = line_starting(l, "MEAS/POINT,F(EDGE_12)");
         l.erase(l.begin() + static_cast<std::ptrdiff_t>(meas - 1));
         return line_starting(l, "PTMEAS/");
       },
       "PTMEAS outside a MEAS block"},
      {"MEAS kind",
       [](auto& l) { return replace_line(l, "MEAS/POINT,F(EDGE_12),2", "MEAS/CIRCLE,F(EDGE_12),2"); },
       "MEAS/CIRCLE of F(EDGE_12), a POINT"},
      {"label syntax",
       [edge12](auto& l) { return replace_line(l, edge12, "F(edge_12)" + edge12.substr(10)); },
       "bad label 'edge_12'"},
      {"LF line ends",
       [](auto& l) {
         l[2] += '\r';
         return std::size_t{3};
       },
       "carriage return: the files use LF line ends"},
      {"plain ASCII",
       [](auto& l) {
         l[2] = "$$ \xc2\xb5m";
         return std::size_t{3};
       },
       "non-ASCII or control character"},
      {"no empty lines",
       [](auto& l) {
         l.insert(l.begin() + 3, "");
         return std::size_t{4};
       },
       "empty line"},
      {"line length",
       [](auto& l) {
         l[2] = "$$ " + std::string(65536, 'x');
         return std::size_t{3};
       },
       "line longer than 65536 characters"},
  };
}

TEST(DmisChecker, RejectsOneMutationPerRuleAtItsLine) {
  const MoveProgram program = hand_program();
  const std::vector<std::string> golden = lines_of(read_text(fs::path(CMMD_TEST_DATA_DIR) / "dmis" / "hand_program.dmi"));
  ASSERT_FALSE(golden.empty());
  ASSERT_TRUE(check_dmis(join(golden), full_check(program)).ok());
  for (const Mutation& m : mutations()) {
    std::vector<std::string> lines = golden;
    const std::size_t line = m.apply(lines);
    const DmisCheckResult r = check_dmis(join(lines), full_check(program));
    EXPECT_EQ(r.line, line) << m.rule << ": " << r;
    EXPECT_NE(r.message.find(m.message), std::string::npos) << m.rule << ": " << r;
  }
}

TEST(DmisChecker, RejectsATextWithoutFinalLineEnd) {
  const std::string text = dmis_of(hand_program(), dmis_features(hand_program(), {bore_hole()}));
  const DmisCheckResult r = check_dmis(text.substr(0, text.size() - 1));
  EXPECT_EQ(r.line, lines_of(text).size());
  EXPECT_EQ(r.message, "no line end after the last line");
}

TEST(DmisExport, SnsetChangesInsideABlockOnlyWhenTouchesDiffer) {
  const MoveProgram program = registration_program();
  const auto lines = lines_of(dmis_of(program, dmis_features(program)));
  const std::size_t meas = line_starting(lines, "MEAS/POINT,F(CORNER_1_0),2");
  ASSERT_GT(meas, 0u);
  EXPECT_EQ(line_starting(lines, "SNSET/APPRCH,5.0000"), line_starting(lines, "SNSET/", meas));
  const std::size_t end = line_starting(lines, "ENDMES");
  EXPECT_LT(line_starting(lines, "SNSET/APPRCH,5.0000"), end);
  EXPECT_EQ(line_starting(lines, "SNSET/APPRCH,3.0000"), line_starting(lines, "SNSET/"));
  // The next feature goes back to 3 mm before its FEAT, outside any block.
  const std::size_t back = line_starting(lines, "SNSET/APPRCH,3.0000", end);
  EXPECT_EQ(back + 2, line_starting(lines, "F(CORNER_1_1)="));  // APPRCH, SEARCH, then the FEAT
}

TEST(DmisExport, RefusesWhatAPtmeasCannotSay) {
  const description::MachineDescription machine = test_machine();
  const auto refused = [&](MoveProgram p, std::vector<DmisFeature> features, const std::string& message) {
    std::ostringstream out;
    try {
      write_dmis(out, p, machine, features, {});
      ADD_FAILURE() << "no refusal; wanted " << message;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
    }
    EXPECT_TRUE(out.str().empty()) << "a refused program wrote " << out.str().size() << " bytes";
  };
  const MoveProgram good = hand_program();
  const std::vector<DmisFeature> features = dmis_features(good, {bore_hole()});

  auto fewer = features;
  fewer[0].touch_ids = {1};
  refused(good, fewer, "touch 2 is in no feature");
  auto twice = features;
  twice[1].touch_ids.push_back(1);
  refused(good, twice, "touch 1 is in both EDGE_12 and EDGE_7");
  auto unknown = features;
  unknown[0].touch_ids.push_back(99);
  refused(good, unknown, "EDGE_12: touch 99 is not in the program");
  auto bad_label = features;
  bad_label[2].label = "FACE-5-0";
  refused(good, bad_label, "label 'FACE-5-0' is not a DMIS label");
  auto long_label = features;
  long_label[2].label = "FACE_12345678901234";
  refused(good, long_label, "is not a DMIS label");
  auto same_label = features;
  same_label[1].label = "EDGE_12";
  refused(good, same_label, "label EDGE_12 is used twice");
  auto not_unit = features;
  not_unit[0].ijk *= 2;
  refused(good, not_unit, "EDGE_12: ijk is not a unit vector");

  MoveProgram p = good;
  p.touches[4].direction *= 1.01;
  refused(p, features, "touch 4: direction is not a unit vector");
  p = good;
  p.touches[4].nominal_centre.z() += 0.5;  // planned for a 1.5 mm ball, the tip has 1 mm
  refused(p, features, "touch 4: nominal centre is not surface point - r*direction");
  p = good;
  p.touches[4].start.x() += 0.1;
  refused(p, features, "touch 4: start is not on the approach line");
  p = good;
  p.touches[4].max_travel_mm = 2;
  refused(p, features, "touch 4: the search ends before the nominal contact");

  description::MachineDescription other = machine;
  other.active_tip = "T9";
  std::ostringstream out;
  EXPECT_THROW(write_dmis(out, good, other, features), std::invalid_argument);
}

TEST(DmisExport, TextsArePlainAsciiAndNumbersHaveNoNegativeZero) {
  MoveProgram p;
  p.home = Vec3(0, 0, 60);
  p.clearance_z = 60;
  Touch t = make_touch(1, TouchTarget::face, Vec3(-0.00001, 20, 5), Vec3(1e-12, -1e-12, -1));
  t.edge_point = 2;
  p.touches = {t};
  p = sequenced(p);
  std::ostringstream out;
  write_dmis(out, p, test_machine(), dmis_features(p), {"it's \xc2\xb5m", "part\tname"});
  const std::string text = out.str();
  EXPECT_EQ(text.find("-0.0"), std::string::npos) << text;
  EXPECT_EQ(text.rfind("DMISMN/'it_s __m',05.2\nFILNAM/'part_name',05.2\n", 0), 0u) << text;
  EXPECT_TRUE(check_dmis(text, full_check(p)).ok()) << check_dmis(text, full_check(p));
}

TEST(DmisExport, SensorLabelFromTheTipId) {
  description::MachineDescription machine = test_machine();
  machine.tips[0].id = "2mm-ruby";
  machine.active_tip = "2mm-ruby";
  const MoveProgram p = registration_program();
  const std::string text = dmis_of(p, dmis_features(p), machine);
  EXPECT_NE(text.find("\nS(TIP2MM_RUBY)=SNSDEF/PROBE,FIXED,CART,0.0000,0.0000,-30.0000,0.000000,0.000000,1.000000,2.0000\n"
                      "SNSLCT/S(TIP2MM_RUBY)\n"),
            std::string::npos)
      << text;
  EXPECT_TRUE(check_dmis(text, full_check(p)).ok()) << check_dmis(text, full_check(p));
}

TEST(DmisExport, FileIsWrittenWholeAndErrorsNameIt) {
  const fs::path dir = fs::temp_directory_path() / ("cmmd_dmis_export_test_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const MoveProgram p = hand_program();
  const auto features = dmis_features(p, {bore_hole()});
  const fs::path file = dir / "out.dmi";
  write_dmis_file(file, p, test_machine(), features, {"cmmd test program", "hand block"});
  EXPECT_EQ(read_text(file), dmis_of(p, features));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1) << "a temp file was left";

  const fs::path missing = dir / "no" / "such" / "dir" / "out.dmi";
  try {
    write_dmis_file(missing, p, test_machine(), features);
    ADD_FAILURE() << "wrote into a missing folder";
  } catch (const cmm::geometry::FileError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(missing.string() + ": ", 0), 0u) << e.what();
    EXPECT_EQ(e.error_number(), ENOENT);
  }
  // A refused program leaves an existing file alone.
  auto bad = features;
  bad.pop_back();
  EXPECT_THROW(write_dmis_file(file, p, test_machine(), bad), std::invalid_argument);
  EXPECT_EQ(read_text(file), dmis_of(p, features));
  fs::remove_all(dir);
}

}  // namespace
