// The strict DMIS checker: one pass over the lines, a small state machine for the order rules, and
// exact token grammars for the numbers we print. Anything outside the subset is a violation.
#include "dmis_checker.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <set>
#include <vector>

namespace cmm::planner::testing {

namespace {

constexpr std::size_t max_line_length = 65536;
constexpr double unit_tolerance = 1e-6;
// Printed coordinates are rounded to 0.1 µm and cosines to 1e-6: comparisons with the program
// allow that rounding and no more.
constexpr double printed_mm = 1e-4;
constexpr double printed_cosine = 2e-6;

struct Violation {
  std::string message;
};

[[noreturn]] void fail(const std::string& message) { throw Violation{message}; }

std::string show(const Vec3& v, int decimals) {
  char buffer[128];
  std::snprintf(buffer, sizeof buffer, "(%.*f,%.*f,%.*f)", decimals, v.x(), decimals, v.y(), decimals, v.z());
  return buffer;
}

bool digits(std::string_view s) {
  if (s.empty()) return false;
  for (const char c : s)
    if (c < '0' || c > '9') return false;
  return true;
}

// -?(0|[1-9][0-9]*)\.[0-9]{decimals}: fixed notation, no exponent, no '+', no bare point.
double fixed_number(std::string_view token, std::size_t decimals) {
  std::string_view body = token;
  if (!body.empty() && body.front() == '-') body.remove_prefix(1);
  const std::size_t point = body.find('.');
  const bool ok = point != std::string_view::npos && digits(body.substr(0, point)) &&
                  (point == 1 || body.front() != '0') && body.size() - point - 1 == decimals &&
                  digits(body.substr(point + 1));
  if (!ok) fail("bad number '" + std::string(token) + "' (fixed notation with " + std::to_string(decimals) + " decimals)");
  const double value = std::strtod(std::string(token).c_str(), nullptr);
  if (token.front() == '-' && value == 0) fail("negative zero '" + std::string(token) + "'");
  return value;
}

double mm(std::string_view token) { return fixed_number(token, 4); }
double cosine(std::string_view token) { return fixed_number(token, 6); }

int count(std::string_view token) {
  if (!digits(token) || token.front() == '0' || token.size() > 6) fail("bad count '" + std::string(token) + "'");
  return std::atoi(std::string(token).c_str());
}

Vec3 point(const std::vector<std::string_view>& a, std::size_t from) {
  return {mm(a[from]), mm(a[from + 1]), mm(a[from + 2])};
}

Vec3 unit(const std::vector<std::string_view>& a, std::size_t from) {
  const Vec3 v(cosine(a[from]), cosine(a[from + 1]), cosine(a[from + 2]));
  if (std::abs(v.norm() - 1) > unit_tolerance) {
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%.9f", v.norm());
    fail("ijk is not a unit vector (length " + std::string(buffer) + ")");
  }
  return v;
}

bool valid_label(std::string_view label) {
  if (label.empty() || label.size() > 16 || label[0] < 'A' || label[0] > 'Z') return false;
  for (const char c : label)
    if (!((c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_')) return false;
  return true;
}

std::vector<std::string_view> split(std::string_view s) {
  std::vector<std::string_view> parts;
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = s.find(',', start);
    parts.push_back(s.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start));
    if (comma == std::string_view::npos) return parts;
    start = comma + 1;
  }
}

// F(label) or S(label) as an argument.
std::string label_ref(std::string_view token, char type) {
  if (token.size() < 4 || token[0] != type || token[1] != '(' || token.back() != ')' ||
      !valid_label(token.substr(2, token.size() - 3)))
    fail("expected " + std::string(1, type) + "(label), got '" + std::string(token) + "'");
  return std::string(token.substr(2, token.size() - 3));
}

void expect(bool condition, const std::string& word, const char* form) {
  if (!condition) fail(word + ": expected " + word + "/" + form);
}

const std::set<std::string_view> known = {"DMISMN", "FILNAM", "UNITS", "MODE", "SNSDEF", "SNSLCT", "FEDRAT",
                                          "SNSET", "FEAT", "MEAS", "GOTO", "PTMEAS", "ENDMES", "ENDFIL"};

class Checker {
 public:
  explicit Checker(const DmisCheckOptions& options) : options_(options) {
    if (options.program) measured_.assign(options.program->touches.size(), false);
  }

  void line(std::string_view text, std::size_t number) {
    if (text.rfind("$$", 0) == 0) {
      if (number == 1) fail("the file must open with DMISMN");
      if (ended_) fail("comment after ENDFIL");
      return;
    }
    statement(text, number);
  }

  void finish() const {
    if (!ended_) fail("missing ENDFIL");
  }

 private:
  void statement(std::string_view text, std::size_t number) {
    if (ended_) fail("statement after ENDFIL");
    // An optional F(label)= or S(label)= in front.
    char label_type = 0;
    std::string label;
    if (text.size() > 2 && (text[0] == 'F' || text[0] == 'S') && text[1] == '(') {
      const std::size_t close = text.find(")=");
      if (close == std::string_view::npos) fail("unknown statement '" + std::string(text.substr(0, text.find('/'))) + "'");
      label_type = text[0];
      label = std::string(text.substr(2, close - 2));
      if (!valid_label(label)) fail("bad label '" + label + "'");
      text.remove_prefix(close + 2);
    }
    const std::size_t slash = text.find('/');
    const std::string word(text.substr(0, slash));
    if (!known.count(word)) fail("unknown statement '" + word + "'");
    const bool has_args = slash != std::string_view::npos;
    const std::string_view args_text = has_args ? text.substr(slash + 1) : std::string_view{};
    if ((word == "ENDMES" || word == "ENDFIL") == has_args)
      fail(word + (has_args ? " takes no arguments" : " needs arguments"));
    const char wanted_label = word == "FEAT" ? 'F' : word == "SNSDEF" ? 'S' : 0;
    if (label_type != wanted_label)
      fail(wanted_label ? word + " needs " + std::string(1, wanted_label) + "(label)=" : word + " takes no label");

    ++statements_;
    if (number == 1 && word != "DMISMN") fail("the file must open with DMISMN");
    if (word == "DMISMN" && number != 1) fail("DMISMN only on line 1");
    if ((statements_ == 2) != (word == "FILNAM")) fail(statements_ == 2 ? "FILNAM must follow DMISMN" : "FILNAM only once, after DMISMN");

    const bool coordinates = word == "SNSDEF" || word == "SNSET" || word == "FEAT" || word == "GOTO" || word == "PTMEAS";
    if (coordinates && !units_) fail(word + " before UNITS");
    const bool moves = word == "GOTO" || word == "MEAS" || word == "PTMEAS";
    if (moves && !mode_) fail(word + " before MODE/PROG,MAN");
    if (moves && !radius_) fail(word + " before SNSLCT: no sensor selected");
    if (block_ && word != "GOTO" && word != "PTMEAS" && word != "SNSET" && word != "ENDMES")
      fail(word + " inside the MEAS block of F(" + block_->label + ") (ENDMES missing)");

    if (word == "DMISMN" || word == "FILNAM") return header(word, args_text);
    const std::vector<std::string_view> a = split(args_text);
    if (word == "UNITS") {
      expect(a.size() == 2 && a[0] == "MM" && a[1] == "ANGDEC", word, "MM,ANGDEC");
      if (units_) fail("UNITS twice");
      units_ = true;
    } else if (word == "MODE") {
      expect(a.size() == 2 && a[0] == "PROG" && a[1] == "MAN", word, "PROG,MAN");
      mode_ = true;
    } else if (word == "SNSDEF") {
      expect(a.size() == 10 && a[0] == "PROBE" && a[1] == "FIXED" && a[2] == "CART", word,
             "PROBE,FIXED,CART,x,y,z,i,j,k,diam");
      point(a, 3);
      unit(a, 6);
      const double diameter = mm(a[9]);
      if (diameter <= 0) fail("SNSDEF: ball diameter must be positive");
      if (!sensors_.emplace(label, diameter / 2).second) fail("duplicate label S(" + label + ")");
    } else if (word == "SNSLCT") {
      expect(a.size() == 1, word, "S(label)");
      const std::string sensor = label_ref(a[0], 'S');
      const auto it = sensors_.find(sensor);
      if (it == sensors_.end()) fail("SNSLCT/S(" + sensor + ") before its SNSDEF");
      radius_ = it->second;
    } else if (word == "FEDRAT") {
      expect(a.size() == 3 && (a[0] == "POSVEL" || a[0] == "MESVEL") && a[1] == "MPM", word, "POSVEL|MESVEL,MPM,v");
      if (mm(a[2]) <= 0) fail("FEDRAT: speed must be positive");
    } else if (word == "SNSET") {
      expect(a.size() == 2 && (a[0] == "APPRCH" || a[0] == "RETRCT" || a[0] == "SEARCH"), word,
             "APPRCH|RETRCT|SEARCH,d");
      const double d = mm(a[1]);
      if (d < 0 || (d == 0 && a[0] != "RETRCT")) fail("SNSET/" + std::string(a[0]) + ": distance must be positive");
      (a[0] == "APPRCH" ? approach_ : a[0] == "RETRCT" ? retract_ : search_) = d;
    } else if (word == "FEAT") {
      feat(label, a);
    } else if (word == "MEAS") {
      meas(a);
    } else if (word == "GOTO") {
      expect(a.size() == 3, word, "x,y,z");
      const Vec3 p = point(a, 0);
      if (options_.travel_box && !options_.travel_box->contains(p, printed_mm))
        fail("GOTO " + show(p, 4) + " outside the travel box");
      position_ = p;
    } else if (word == "PTMEAS") {
      ptmeas(a);
    } else if (word == "ENDMES") {
      if (!block_) fail("ENDMES without MEAS");
      if (block_->taken != block_->count)
        fail("MEAS of F(" + block_->label + ") announces " + std::to_string(block_->count) + " PTMEAS, has " +
             std::to_string(block_->taken));
      block_.reset();
    } else if (word == "ENDFIL") {
      if (options_.program)
        for (std::size_t i = 0; i < measured_.size(); ++i)
          if (!measured_[i]) fail("touch " + std::to_string(options_.program->touches[i].id) + " is never measured");
      ended_ = true;
    }
  }

  void header(const std::string& word, std::string_view args) {
    // 'text',NN.N: the text has no quote of its own, so the first quote after the opening one closes it.
    const std::size_t close = args.size() > 1 && args[0] == '\'' ? args.find('\'', 1) : std::string_view::npos;
    const std::string_view version = close == std::string_view::npos ? std::string_view{} : args.substr(close + 1);
    const bool ok = close != std::string_view::npos && version.size() == 5 && version[0] == ',' &&
                    digits(version.substr(1, 2)) && version[3] == '.' && digits(version.substr(4));
    expect(ok, word, "'text',NN.N");
  }

  void feat(const std::string& label, const std::vector<std::string_view>& a) {
    if (a.empty()) expect(false, "FEAT", "POINT|CIRCLE,...");
    Feature f;
    if (a[0] == "POINT") {
      expect(a.size() == 8 && a[1] == "CART", "FEAT", "POINT,CART,x,y,z,i,j,k");
      point(a, 2);
      unit(a, 5);
    } else if (a[0] == "CIRCLE") {
      expect(a.size() == 10 && (a[1] == "INNER" || a[1] == "OUTER") && a[2] == "CART", "FEAT",
             "CIRCLE,INNER|OUTER,CART,x,y,z,i,j,k,diam");
      point(a, 3);
      unit(a, 6);
      if (mm(a[9]) <= 0) fail("FEAT/CIRCLE: diameter must be positive");
    } else {
      expect(false, "FEAT", "POINT|CIRCLE,...");
    }
    f.kind = std::string(a[0]);
    if (!features_.emplace(label, f).second) fail("duplicate label F(" + label + ")");
  }

  void meas(const std::vector<std::string_view>& a) {
    if (block_) fail("MEAS inside the MEAS block of F(" + block_->label + ") (ENDMES missing)");
    expect(a.size() == 3 && (a[0] == "POINT" || a[0] == "CIRCLE"), "MEAS", "POINT|CIRCLE,F(label),n");
    const std::string label = label_ref(a[1], 'F');
    const auto it = features_.find(label);
    if (it == features_.end()) fail("MEAS of F(" + label + "), which no FEAT defines before it");
    if (it->second.kind != a[0]) fail("MEAS/" + std::string(a[0]) + " of F(" + label + "), a " + it->second.kind);
    if (it->second.measured) fail("F(" + label + ") measured twice");
    it->second.measured = true;
    block_ = Block{label, count(a[2]), 0};
  }

  void ptmeas(const std::vector<std::string_view>& a) {
    if (!block_) fail("PTMEAS outside a MEAS block");
    expect(a.size() == 7 && a[0] == "CART", "PTMEAS", "CART,x,y,z,i,j,k");
    const Vec3 p = point(a, 1);
    const Vec3 n = unit(a, 4);
    if (++block_->taken > block_->count)
      fail("MEAS of F(" + block_->label + ") announces " + std::to_string(block_->count) + " PTMEAS, this is one more");
    // xyz is the surface point; the ball centre sits r out along the normal.
    const Vec3 centre = p + *radius_ * n;
    if (options_.travel_box && !options_.travel_box->contains(centre, printed_mm))
      fail("PTMEAS ball centre " + show(centre, 4) + " outside the travel box");
    if (options_.program) match_touch(p, n);  // also says where the retract leaves the ball
    else position_.reset();
  }

  void match_touch(const Vec3& p, const Vec3& n) {
    const std::vector<Touch>& touches = options_.program->touches;
    std::vector<std::size_t> here;
    bool seen = false;
    for (std::size_t i = 0; i < touches.size(); ++i) {
      if ((touches[i].surface_point - p).norm() > printed_mm) continue;
      if (measured_[i]) seen = true;
      else here.push_back(i);
    }
    if (here.empty()) fail(seen ? "PTMEAS at " + show(p, 4) + " measures a touch a second time"
                                : "PTMEAS at " + show(p, 4) + " is no touch of the program");
    const Touch* touch = nullptr;
    for (const std::size_t i : here)
      if ((n + touches[i].direction).norm() <= printed_cosine) {
        touch = &touches[i];
        measured_[i] = true;
        break;
      }
    if (!touch) {
      const Touch& t = touches[here.front()];
      fail("PTMEAS ijk is not -(approach direction) of touch " + std::to_string(t.id) + ": expected " +
           show(-t.direction, 6));
    }
    const std::string name = "touch " + std::to_string(touch->id);
    if (!position_ || (*position_ - touch->start).norm() > printed_mm)
      fail("PTMEAS of " + name + " not reached from its approach start " + show(touch->start, 4));
    const double approach = (touch->nominal_centre - touch->start).dot(touch->direction);
    if (!approach_ || std::abs(*approach_ - approach) > printed_mm)
      fail("SNSET/APPRCH does not match the approach of " + name);
    if (!search_ || std::abs(*search_ - (touch->max_travel_mm - approach)) > printed_mm)
      fail("SNSET/SEARCH does not match the search of " + name);
    if (!retract_ || std::abs(*retract_ - touch->retract_mm) > printed_mm)
      fail("SNSET/RETRCT does not match the retract of " + name);
    // Where the DME leaves the ball after a nominal contact and its retract.
    position_ = touch->nominal_centre - touch->retract_mm * touch->direction;
  }

  struct Feature {
    std::string kind;
    bool measured = false;
  };
  struct Block {
    std::string label;
    int count = 0, taken = 0;
  };

  const DmisCheckOptions& options_;
  std::size_t statements_ = 0;
  bool units_ = false, mode_ = false, ended_ = false;
  std::map<std::string, double> sensors_;  // label -> ball radius
  std::optional<double> radius_;           // of the selected sensor
  std::map<std::string, Feature> features_;
  std::optional<Block> block_;
  std::optional<double> approach_, retract_, search_;
  std::vector<bool> measured_;
  // The ball centre as the program left it, where the next PTMEAS starts: set by GOTO, and after a
  // PTMEAS only when the program says where its retract ends.
  std::optional<Vec3> position_;
};

}  // namespace

std::ostream& operator<<(std::ostream& out, const DmisCheckResult& result) {
  if (result.ok()) return out << "DMIS ok";
  return out << "line " << result.line << ": " << result.message;
}

DmisCheckResult check_dmis(std::string_view text, const DmisCheckOptions& options) {
  Checker checker(options);
  std::size_t number = 0;
  std::size_t start = 0;
  try {
    if (text.empty()) {
      number = 1;
      fail("empty file");
    }
    while (start < text.size()) {
      ++number;
      const std::size_t end = text.find('\n', start);
      if (end == std::string_view::npos) fail("no line end after the last line");
      const std::string_view line = text.substr(start, end - start);
      start = end + 1;
      if (line.size() > max_line_length) fail("line longer than 65536 characters");
      for (const char c : line) {
        if (c == '\r') fail("carriage return: the files use LF line ends");
        if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) > 0x7e)
          fail("non-ASCII or control character");
      }
      if (line.empty()) fail("empty line");
      checker.line(line, number);
    }
    checker.finish();
  } catch (const Violation& v) {
    return {number, v.message};
  }
  return {};
}

}  // namespace cmm::planner::testing
