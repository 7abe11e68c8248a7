// DMIS export: checks that every touch is something a DME can do from a PTMEAS, then prints the
// program; the text is built whole first so that a refused program writes nothing.
#include "planner/dmis_export.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <ostream>
#include <set>
#include <sstream>
#include <stdexcept>
#include <tuple>
#include <unordered_map>

#include "geometry/atomic_file.hpp"
#include "geometry/file_error.hpp"

namespace cmm::planner {

namespace {

// Tolerances on the touches we are given: they come from double arithmetic, so anything beyond
// these is a planning error, not rounding.
constexpr double unit_tolerance = 1e-6;
constexpr double length_tolerance_mm = 1e-6;
constexpr std::size_t max_label_length = 16;
constexpr std::size_t max_text_length = 64;

[[noreturn]] void refuse(const std::string& message) { throw std::invalid_argument("DMIS export: " + message); }

std::string fixed(double value, int decimals) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", decimals, value);
  std::string text = buffer;
  // "-0.0000" reads as a sign error to a person comparing files; print zero one way.
  if (text.find_first_not_of("-0.") == std::string::npos && text.front() == '-') text.erase(0, 1);
  return text;
}

// 0.1 µm for lengths, 1e-6 for direction cosines (an angle of 0.2″).
std::string mm(double value) { return fixed(value, 4); }
std::string cosine(double value) { return fixed(value, 6); }
std::string xyz(const Vec3& p) { return mm(p.x()) + "," + mm(p.y()) + "," + mm(p.z()); }
std::string ijk(const Vec3& v) { return cosine(v.x()) + "," + cosine(v.y()) + "," + cosine(v.z()); }

// DMIS text strings are quoted with ' and have no escape; keep them plain printable ASCII.
std::string dmis_text(const std::string& text) {
  std::string out;
  for (const char c : text.substr(0, max_text_length)) {
    const auto u = static_cast<unsigned char>(c);
    out += (u >= 0x20 && u < 0x7f && c != '\'') ? c : '_';
  }
  return out;
}

bool valid_label(const std::string& label) {
  if (label.empty() || label.size() > max_label_length || label[0] < 'A' || label[0] > 'Z') return false;
  return std::all_of(label.begin(), label.end(),
                     [](char c) { return (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_'; });
}

// The sensor label from the tip id: upper case, other characters as _, a leading letter.
std::string sensor_label(const std::string& tip_id) {
  std::string label;
  for (const char c : tip_id) {
    if (c >= 'a' && c <= 'z') label += static_cast<char>(c - 'a' + 'A');
    else if ((c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9')) label += c;
    else label += '_';
  }
  if (label.empty() || label[0] < 'A' || label[0] > 'Z') label = "TIP" + label;
  return label.substr(0, max_label_length);
}

const description::StylusTip& active_tip(const description::MachineDescription& machine) {
  for (const description::StylusTip& tip : machine.tips)
    if (tip.id == machine.active_tip) return tip;
  refuse("the machine has no tip '" + machine.active_tip + "' (its active_tip)");
}

bool finite(const Vec3& v) { return v.allFinite(); }

// What the DME is told for one touch: the SNSET distances that make its PTMEAS move exactly the
// planned probing motion from the planned start.
struct TouchMotion {
  double approach_mm;  // start to nominal ball centre
  double search_mm;    // past the nominal ball centre
  double retract_mm;
};

TouchMotion check_touch(const Touch& t, double r) {
  const std::string name = "touch " + std::to_string(t.id);
  if (!finite(t.surface_point) || !finite(t.direction) || !finite(t.nominal_centre) || !finite(t.start) ||
      !std::isfinite(t.max_travel_mm) || !std::isfinite(t.retract_mm))
    refuse(name + ": a coordinate or distance is not finite");
  if (std::abs(t.direction.norm() - 1) > unit_tolerance) refuse(name + ": direction is not a unit vector");
  if ((t.nominal_centre - (t.surface_point - r * t.direction)).norm() > length_tolerance_mm)
    refuse(name + ": nominal centre is not surface point - r*direction for its tip's ball radius r = " + mm(r) + " mm");
  const Vec3 to_contact = t.nominal_centre - t.start;
  const double approach = to_contact.dot(t.direction);
  if (approach <= length_tolerance_mm || (to_contact - approach * t.direction).norm() > length_tolerance_mm)
    refuse(name + ": start is not on the approach line behind the nominal contact, which a PTMEAS cannot express");
  if (t.max_travel_mm - approach <= 0) refuse(name + ": the search ends before the nominal contact");
  if (t.retract_mm < 0) refuse(name + ": negative retract");
  return {approach, t.max_travel_mm - approach, t.retract_mm};
}

void check_feature(const DmisFeature& f) {
  if (!valid_label(f.label))
    refuse("label '" + f.label + "' is not a DMIS label we emit ([A-Z][A-Z0-9_]*, at most 16 characters)");
  if (!finite(f.nominal) || !finite(f.ijk)) refuse(f.label + ": nominal or ijk is not finite");
  if (std::abs(f.ijk.norm() - 1) > unit_tolerance) refuse(f.label + ": ijk is not a unit vector");
  if (f.kind == DmisFeature::Kind::circle && !(f.diameter_mm > 0 && std::isfinite(f.diameter_mm)))
    refuse(f.label + ": a circle needs a positive diameter");
  if (f.touch_ids.empty()) refuse(f.label + ": no touches");
}

const char* kind_word(DmisFeature::Kind kind) { return kind == DmisFeature::Kind::circle ? "CIRCLE" : "POINT"; }

std::string feat_statement(const DmisFeature& f) {
  std::string s = "F(" + f.label + ")=FEAT/" + kind_word(f.kind) + ",";
  if (f.kind == DmisFeature::Kind::circle) s += f.inner ? "INNER," : "OUTER,";
  s += "CART," + xyz(f.nominal) + "," + ijk(f.ijk);
  if (f.kind == DmisFeature::Kind::circle) s += "," + mm(f.diameter_mm);
  return s;
}

// Emits the program's moves as GOTOs. A move whose end prints the same as where the ball is would be
// a zero-length GOTO (a return to a start the retract already reached): left out.
class GotoPath {
 public:
  GotoPath(std::ostringstream& out, const Vec3& at) : out_(out), at_(xyz(at)) {
    out_ << "GOTO/" << at_ << '\n';
  }
  void go(const Vec3& p) {
    const std::string text = xyz(p);
    if (text != at_) out_ << "GOTO/" << text << '\n';
    at_ = text;
  }
  void moved_to(const Vec3& p) { at_ = xyz(p); }  // a motion the DME makes by itself (PTMEAS and its retract)

 private:
  std::ostringstream& out_;
  std::string at_;
};

// The SNSET distances in force; a statement only when one changes.
class SensorSettings {
 public:
  explicit SensorSettings(std::ostringstream& out) : out_(out) {}
  void set(const TouchMotion& m) {
    put("APPRCH", approach_, mm(m.approach_mm));
    put("RETRCT", retract_, mm(m.retract_mm));
    put("SEARCH", search_, mm(m.search_mm));
  }

 private:
  void put(const char* word, std::string& current, const std::string& value) {
    if (current == value) return;
    out_ << "SNSET/" << word << ',' << value << '\n';
    current = value;
  }
  std::ostringstream& out_;
  std::string approach_, retract_, search_;
};

Vec3 outward_from(const std::vector<const Touch*>& touches) {
  Vec3 sum = Vec3::Zero();
  for (const Touch* t : touches) sum += t->direction;
  // Two touches of an edge point are symmetric about the window axis, so their sum lies on it; a
  // sum near zero (opposed touches) has no meaning, and the first touch's normal stands in.
  if (sum.norm() < 1e-9) return -touches.front()->direction.normalized();
  return -sum.normalized();
}

Vec3 mean_surface_point(const std::vector<const Touch*>& touches) {
  Vec3 sum = Vec3::Zero();
  for (const Touch* t : touches) sum += t->surface_point;
  return sum / static_cast<double>(touches.size());
}

// Bore touches approach radially, so each surface point is centre + R·u (u its direction's part
// square to the axis): a linear least-squares problem in the centre and R.
void fit_circle(DmisFeature& f, const std::vector<const Touch*>& touches, double clearance_z) {
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Touch* t : touches) scatter += t->direction * t->direction.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(scatter);
  // Directions square to the axis leave the axis with the smallest eigenvalue; the touches must
  // span the plane, else there is no circle to fit.
  if (touches.size() < 3 || eigen.eigenvalues()(1) < 1e-6 * eigen.eigenvalues()(2))
    refuse(f.label + ": cannot fit a circle to " + std::to_string(touches.size()) +
           " touches that do not span a plane; pass its hole");
  Vec3 axis = eigen.eigenvectors().col(0).normalized();
  const auto n = static_cast<Eigen::Index>(touches.size());
  Eigen::MatrixXd a(3 * n, 4);
  Eigen::VectorXd b(3 * n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Touch& t = *touches[static_cast<std::size_t>(i)];
    const Vec3 u = (t.direction - t.direction.dot(axis) * axis).normalized();
    a.block<3, 3>(3 * i, 0).setIdentity();
    a.block<3, 1>(3 * i, 3) = u;
    b.segment<3>(3 * i) = t.surface_point;
  }
  const Eigen::Vector4d x = a.colPivHouseholderQr().solve(b);
  f.nominal = x.head<3>();
  f.diameter_mm = 2 * std::abs(x(3));
  f.inner = x(3) > 0;  // touches moving away from the axis are on a bore's wall
  // The axis points to where the probe comes from, the clearance plane; a horizontal one by +y, +x.
  double side = axis.z() * (clearance_z - f.nominal.z());
  if (std::abs(axis.z()) < 1e-9) side = std::abs(axis.y()) > 1e-9 ? axis.y() : axis.x();
  f.ijk = side < 0 ? Vec3(-axis) : axis;
}

}  // namespace

std::vector<DmisFeature> dmis_features(const MoveProgram& program, const std::vector<geometry::Hole>& holes) {
  std::map<std::tuple<int, int, int>, std::size_t> index;  // (target, owner, face) -> feature
  std::vector<DmisFeature> features;
  std::vector<std::vector<const Touch*>> members;
  for (const Touch& t : program.touches) {
    const std::string name = "touch " + std::to_string(t.id);
    std::tuple<int, int, int> key;
    std::string label;
    switch (t.target) {
      case TouchTarget::edge:
        if (t.edge_point < 0) refuse(name + ": an edge touch without its edge point");
        key = {0, t.edge_point, 0};
        label = "EDGE_" + std::to_string(t.edge_point);
        break;
      case TouchTarget::face:
        if (t.edge_point < 0 || t.face < 0) refuse(name + ": a face touch without its edge point and face");
        key = {1, t.edge_point, t.face};
        label = "FACE_" + std::to_string(t.edge_point) + "_" + std::to_string(t.face);
        break;
      case TouchTarget::bore:
        if (t.hole < 0) refuse(name + ": a bore touch without its hole");
        key = {2, t.hole, 0};
        label = "BORE_" + std::to_string(t.hole);
        break;
      case TouchTarget::plate_face:
        // One feature per face: the DME reports each as a point on its plane, and the corner is
        // the three planes' intersection, constructed afterwards.
        if (t.corner < 0 || t.face < 0) refuse(name + ": a plate-face touch without its corner and face");
        key = {3, t.corner, t.face};
        label = "CORNER_" + std::to_string(t.corner) + "_" + std::to_string(t.face);
        break;
      case TouchTarget::fiducial:
        key = {4, 0, 0};
        label = "FIDUCIAL";
        break;
    }
    auto [it, added] = index.emplace(key, features.size());
    if (added) {
      DmisFeature f;
      f.label = label;
      f.kind = t.target == TouchTarget::bore ? DmisFeature::Kind::circle : DmisFeature::Kind::point;
      features.push_back(std::move(f));
      members.emplace_back();
    }
    features[it->second].touch_ids.push_back(t.id);
    members[it->second].push_back(&t);
  }
  for (std::size_t i = 0; i < features.size(); ++i) {
    DmisFeature& f = features[i];
    const std::vector<const Touch*>& touches = members[i];
    if (f.kind == DmisFeature::Kind::point) {
      f.nominal = mean_surface_point(touches);
      f.ijk = outward_from(touches);
      continue;
    }
    const int hole_id = touches.front()->hole;
    const auto hole = std::find_if(holes.begin(), holes.end(), [&](const geometry::Hole& h) { return h.id == hole_id; });
    if (hole == holes.end()) {
      fit_circle(f, touches, program.clearance_z);
      continue;
    }
    // The model's nominal, moved along the axis to the depth the touches are at.
    f.ijk = hole->axis.normalized();
    f.nominal = hole->centre + f.ijk * f.ijk.dot(mean_surface_point(touches) - hole->centre);
    f.diameter_mm = 2 * hole->radius;
    f.inner = true;
  }
  return features;
}

void write_dmis(std::ostream& out, const MoveProgram& program, const description::MachineDescription& machine,
                const std::vector<DmisFeature>& features, const DmisOptions& options) {
  const description::StylusTip& tip = active_tip(machine);
  if (!(tip.ball_radius_mm > 0 && std::isfinite(tip.ball_radius_mm))) refuse("the active tip's ball radius is not positive");
  if (std::abs(tip.direction.norm() - 1) > unit_tolerance) refuse("the active tip's direction is not a unit vector");
  if (!(machine.max_speed_mm_s > 0) || !(machine.probe_speed_mm_s > 0)) refuse("the machine's speeds are not positive");
  if (!finite(program.home) || !std::isfinite(program.clearance_z)) refuse("home or clearance plane is not finite");

  std::unordered_map<int, std::size_t> by_id;  // touch id -> index in program order
  std::vector<TouchMotion> motions;
  for (std::size_t i = 0; i < program.touches.size(); ++i) {
    const Touch& t = program.touches[i];
    if (!by_id.emplace(t.id, i).second) refuse("two touches have id " + std::to_string(t.id));
    const description::StylusTip* own = t.tip.empty() ? &tip : machine.find_tip(t.tip);
    if (own == nullptr) refuse("touch " + std::to_string(t.id) + " is made with tip " + t.tip + ", which the machine does not have");
    motions.push_back(check_touch(t, own->ball_radius_mm));
  }
  std::set<std::string> labels;
  std::vector<int> owner(program.touches.size(), -1);
  std::vector<std::pair<std::size_t, std::size_t>> order;  // (first touch in program, feature)
  for (std::size_t k = 0; k < features.size(); ++k) {
    const DmisFeature& f = features[k];
    check_feature(f);
    if (!labels.insert(f.label).second) refuse("label " + f.label + " is used twice");
    std::size_t first = program.touches.size();
    for (const int id : f.touch_ids) {
      const auto it = by_id.find(id);
      if (it == by_id.end()) refuse(f.label + ": touch " + std::to_string(id) + " is not in the program");
      if (owner[it->second] >= 0)
        refuse("touch " + std::to_string(id) + " is in both " + features[static_cast<std::size_t>(owner[it->second])].label +
               " and " + f.label);
      owner[it->second] = static_cast<int>(k);
      first = std::min(first, it->second);
    }
    order.emplace_back(first, k);
  }
  for (std::size_t i = 0; i < owner.size(); ++i)
    if (owner[i] < 0) refuse("touch " + std::to_string(program.touches[i].id) + " is in no feature");
  std::vector<int> searches(program.touches.size(), 0);
  for (const Motion& m : program.motions)
    if (const auto it = by_id.find(m.touch); m.kind == MotionKind::probe && it != by_id.end()) ++searches[it->second];
  for (std::size_t i = 0; i < searches.size(); ++i)
    if (searches[i] != 1)
      refuse("touch " + std::to_string(program.touches[i].id) + " has " + std::to_string(searches[i]) +
             " probe motions in the program, not one");
  std::sort(order.begin(), order.end());

  std::ostringstream s;
  s << "DMISMN/'" << dmis_text(options.program_name) << "',05.2\n";
  s << "FILNAM/'" << dmis_text(options.part_name) << "',05.2\n";
  s << "$$ cmmd move program: touches " << program.touches.size() << ", features " << features.size()
    << "; machine frame M, mm; GOTO positions are ball centres\n";
  s << "UNITS/MM,ANGDEC\n";
  s << "MODE/PROG,MAN\n";
  // Every tip the program uses, the active one first. FIXED,CART: the ball centre's offset from the
  // probe's reference point, then the stylus vector from the ball toward the head (0,0,1 for a
  // vertical probe), then the ball diameter.
  std::vector<const description::StylusTip*> used{&tip};
  for (const Motion& m : program.motions)
    if (m.kind == MotionKind::change_tip) {
      const description::StylusTip* next = machine.find_tip(m.tip);
      if (next == nullptr) refuse("the program changes to tip " + m.tip + ", which the machine does not have");
      if (std::find(used.begin(), used.end(), next) == used.end()) used.push_back(next);
    }
  for (const description::StylusTip* t : used) {
    if (!(t->ball_radius_mm > 0 && std::isfinite(t->ball_radius_mm))) refuse("tip " + t->id + "'s ball radius is not positive");
    s << "S(" << sensor_label(t->id) << ")=SNSDEF/PROBE,FIXED,CART," << xyz(t->offset) << ","
      << ijk(-t->direction.normalized()) << "," << mm(2 * t->ball_radius_mm) << '\n';
  }
  s << "SNSLCT/S(" << sensor_label(tip.id) << ")\n";
  // m/min, the one speed unit every DMIS version has; 4 decimals resolve 0.002 mm/s.
  s << "FEDRAT/POSVEL,MPM," << mm(machine.max_speed_mm_s * 0.06) << '\n';
  s << "FEDRAT/MESVEL,MPM," << mm(machine.probe_speed_mm_s * 0.06) << '\n';

  // The program's own motions, feature block by feature block: a MEAS block holds every touch of its
  // feature, so a program that interleaves two features cannot be written as it runs.
  std::vector<std::size_t> feature_of(program.touches.size());
  for (std::size_t i = 0; i < owner.size(); ++i) feature_of[i] = static_cast<std::size_t>(owner[i]);
  SensorSettings settings(s);
  if (!order.empty()) settings.set(motions[by_id.at(features[order.front().second].touch_ids.front())]);
  GotoPath path(s, program.home);  // the DME's position before the program is unknown: go home first
  constexpr std::size_t none = static_cast<std::size_t>(-1);
  std::size_t open = none;  // the feature whose MEAS block is open
  std::set<std::size_t> closed;
  const auto close = [&] {
    if (open == none) return;
    s << "ENDMES\n";
    closed.insert(open);
    open = none;
  };
  for (const Motion& m : program.motions) {
    const auto touch = by_id.find(m.touch);
    if (m.touch >= 0 && touch == by_id.end())
      refuse("a motion belongs to touch " + std::to_string(m.touch) + ", which is not in the program");
    if (m.kind == MotionKind::change_tip) {
      close();
      s << "SNSLCT/S(" << sensor_label(m.tip) << ")\n";
      path.moved_to(m.to);  // the same place; the new tip's ball centre is elsewhere by the offsets' difference
      continue;
    }
    if (touch == by_id.end()) {
      close();
    } else if (const std::size_t k = feature_of[touch->second]; open != k) {
      close();
      const DmisFeature& f = features[k];
      if (closed.contains(k))
        refuse(f.label + ": its touches are not one after the other in the program (touch " + std::to_string(m.touch) +
               " comes after another feature's), and a MEAS block cannot be split");
      settings.set(motions[by_id.at(f.touch_ids.front())]);
      s << feat_statement(f) << '\n';
      s << "MEAS/" << kind_word(f.kind) << ",F(" << f.label << ")," << f.touch_ids.size() << '\n';
      open = k;
    }
    if (m.kind == MotionKind::probe) {
      const Touch& t = program.touches[touch->second];
      settings.set(motions[touch->second]);  // inside the block only when touches of one feature differ
      // DMIS ijk is the surface normal out of the material; the DME approaches along -ijk.
      s << "PTMEAS/CART," << xyz(t.surface_point) << "," << ijk(-t.direction) << '\n';
      path.moved_to(m.to);  // the DME's own search and retract
    } else {
      path.go(m.to);
    }
  }
  close();
  s << "ENDFIL\n";
  out << s.str();
}

void write_dmis_file(const std::filesystem::path& file, const MoveProgram& program,
                     const description::MachineDescription& machine, const std::vector<DmisFeature>& features,
                     const DmisOptions& options) {
  std::ostringstream text;
  write_dmis(text, program, machine, features, options);
  geometry::write_atomically(file, text.str());
}

}  // namespace cmm::planner
