// Parsing and printing I++ DME lines: a small recursive-descent reader of the method-call grammar
// (name(args), dotted names, numbers, "strings"), the reply markers, and the error table.
#include "hal/ippdme_protocol.hpp"

#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>

namespace cmm::hal::ippdme {

namespace {

// The grammar of one line after its tag:
//   call  := name '(' [arg {',' arg}] ')'        name := ident {'.' ident}
//   arg   := number | "string" | name | call     spaces allowed around args and commas
class Reader {
 public:
  explicit Reader(std::string_view text) : s_(text) {}

  bool at_end() {
    skip_spaces();
    return i_ >= s_.size();
  }
  std::size_t position() const { return i_; }
  const std::string& error() const { return error_; }

  std::optional<Term> term() {
    skip_spaces();
    if (i_ >= s_.size()) return fail("an argument expected at the end of the line");
    const char c = s_[i_];
    if (c == '"') return string();
    if (c == '-' || c == '+' || c == '.' || (c >= '0' && c <= '9')) return number();
    if (is_ident_start(c)) return name_or_call();
    return fail(std::string("unexpected '") + c + "'");
  }

  // Comma-separated terms up to `close` (or the end of the line when close is 0).
  std::optional<std::vector<Term>> terms(char close) {
    std::vector<Term> out;
    skip_spaces();
    if (close != 0 && i_ < s_.size() && s_[i_] == close) return out;
    if (close == 0 && i_ >= s_.size()) return out;
    for (;;) {
      auto t = term();
      if (!t) return std::nullopt;
      out.push_back(std::move(*t));
      skip_spaces();
      if (i_ < s_.size() && s_[i_] == ',') {
        ++i_;
        continue;
      }
      if (close == 0 ? i_ >= s_.size() : (i_ < s_.size() && s_[i_] == close)) return out;
      if (i_ >= s_.size()) return fail(std::string("missing '") + close + "'"), std::nullopt;
      return fail(std::string("unexpected '") + s_[i_] + "'"), std::nullopt;
    }
  }

 private:
  static bool is_ident_start(char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || c == '_'; }
  static bool is_ident(char c) { return is_ident_start(c) || (c >= '0' && c <= '9'); }
  void skip_spaces() {
    while (i_ < s_.size() && s_[i_] == ' ') ++i_;
  }
  std::nullopt_t fail(std::string why) {
    if (error_.empty()) error_ = why + " at column " + std::to_string(i_ + 7);  // after "00001 "
    return std::nullopt;
  }

  std::optional<Term> string() {
    const std::size_t close = s_.find('"', i_ + 1);
    if (close == std::string_view::npos) return fail("an unterminated string");
    Term t;
    t.kind = Term::Kind::string;
    t.text = std::string(s_.substr(i_ + 1, close - i_ - 1));
    i_ = close + 1;
    return t;
  }

  std::optional<Term> number() {
    std::size_t end = i_;
    while (end < s_.size() && (std::string_view("0123456789+-.eE").find(s_[end]) != std::string_view::npos)) ++end;
    std::string_view text = s_.substr(i_, end - i_);
    if (!text.empty() && text.front() == '+') text.remove_prefix(1);
    double v = 0;
    auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
    if (ec != std::errc() || ptr != text.data() + text.size() || text.empty() || !std::isfinite(v))
      return fail("a malformed number \"" + std::string(s_.substr(i_, end - i_)) + "\"");
    i_ = end;
    return number_term(v);
  }

  std::optional<Term> name_or_call() {
    std::string name;
    for (;;) {
      const std::size_t begin = i_;
      while (i_ < s_.size() && is_ident(s_[i_])) ++i_;
      if (i_ == begin) return fail("a name expected");
      name.append(s_.substr(begin, i_ - begin));
      if (i_ < s_.size() && s_[i_] == '.' && i_ + 1 < s_.size() && is_ident_start(s_[i_ + 1])) {
        name.push_back('.');
        ++i_;
        continue;
      }
      break;
    }
    Term t;
    t.text = std::move(name);
    if (i_ >= s_.size() || s_[i_] != '(') {
      t.kind = Term::Kind::name;
      return t;
    }
    ++i_;
    if (++depth_ > 16) return fail("arguments nested too deep");
    auto args = terms(')');
    --depth_;
    if (!args) return std::nullopt;
    ++i_;  // ')'
    t.kind = Term::Kind::call;
    t.args = std::move(*args);
    return t;
  }

  std::string_view s_;
  std::size_t i_ = 0;
  int depth_ = 0;
  std::string error_;
};

bool printable(std::string_view line, std::size_t& bad) {
  for (std::size_t i = 0; i < line.size(); ++i) {
    const auto c = static_cast<unsigned char>(line[i]);
    if (c < 32 || c > 126) {
      bad = i;
      return false;
    }
  }
  return true;
}

}  // namespace

std::string format_tag(Tag tag) {
  char text[8];
  if (tag.event) std::snprintf(text, sizeof text, "E%04d", tag.number % 10000);
  else std::snprintf(text, sizeof text, "%05d", tag.number % 100000);
  return text;
}

std::optional<Tag> parse_tag(std::string_view five) {
  if (five.size() != 5) return std::nullopt;
  Tag tag;
  std::string_view digits = five;
  if (five[0] == 'E') {
    tag.event = true;
    digits.remove_prefix(1);
  }
  for (char c : digits)
    if (c < '0' || c > '9') return std::nullopt;
  std::from_chars(digits.data(), digits.data() + digits.size(), tag.number);
  if (!tag.event && tag.number == 0) return std::nullopt;  // 00000 is no tag
  return tag;
}

Term number_term(double value) {
  Term t;
  t.kind = Term::Kind::number;
  t.number = value;
  return t;
}

Term call_term(std::string name, std::vector<Term> args) {
  Term t;
  t.kind = Term::Kind::call;
  t.text = std::move(name);
  t.args = std::move(args);
  return t;
}

std::string format_number(double value) {
  char text[352];  // the largest finite double has 309 digits before the point
  const double pm = std::round(value * 1e9);
  std::snprintf(text, sizeof text, "%.9f", pm == 0 ? 0.0 : value);  // never "-0.000000000"
  return text;
}

std::string format_term(const Term& t) {
  switch (t.kind) {
    case Term::Kind::number: return format_number(t.number);
    case Term::Kind::string: return "\"" + t.text + "\"";
    case Term::Kind::name: return t.text;
    case Term::Kind::call: return t.text + "(" + format_terms(t.args) + ")";
  }
  return {};
}

std::string format_terms(const std::vector<Term>& terms) {
  std::string out;
  for (std::size_t i = 0; i < terms.size(); ++i) {
    if (i > 0) out += ", ";
    out += format_term(terms[i]);
  }
  return out;
}

const Term* find_call(const std::vector<Term>& items, std::string_view name) {
  for (const Term& t : items)
    if (t.kind == Term::Kind::call && t.text == name) return &t;
  return nullptr;
}

std::optional<double> number_of(const std::vector<Term>& items, std::string_view name) {
  const Term* t = find_call(items, name);
  if (!t || t->args.size() != 1 || t->args[0].kind != Term::Kind::number) return std::nullopt;
  return t->args[0].number;
}

std::optional<Vec3> vector_of(const std::vector<Term>& items, std::string_view name) {
  const Term* t = find_call(items, name);
  if (!t || t->args.size() != 3) return std::nullopt;
  Vec3 v;
  for (int i = 0; i < 3; ++i) {
    const Term& a = t->args[static_cast<std::size_t>(i)];
    if (a.kind != Term::Kind::number) return std::nullopt;
    v[i] = a.number;
  }
  return v;
}

std::string format_command(const Command& c) { return format_tag(c.tag) + " " + c.name + "(" + format_terms(c.args) + ")"; }

std::variant<Command, LineError> parse_command(std::string_view line) {
  auto error = [&](int code, std::string text, std::optional<Tag> tag) { return LineError{code, std::move(text), tag}; };
  const std::optional<Tag> tag = line.size() >= 5 ? parse_tag(line.substr(0, 5)) : std::nullopt;
  if (line.size() > kMaxLineChars)
    return error(kErrorBufferFull, "line longer than " + std::to_string(kMaxLineChars) + " characters", tag);
  std::size_t bad = 0;
  if (!printable(line, bad))
    return error(kErrorIllegalCharacter, "character " + std::to_string(static_cast<unsigned char>(line[bad])) +
                                             " at column " + std::to_string(bad + 1) + " is outside ASCII 32-126", tag);
  if (!tag) return error(kErrorIllegalTag, "a line starts with a tag 00001-99999 or E0001-E9999", std::nullopt);
  if (line.size() < 6 || line[5] != ' ') return error(kErrorNoSpace, "no space after the tag", tag);
  Reader r(line.substr(6));
  auto call = r.term();
  if (!call || call->kind != Term::Kind::call)
    return error(kErrorProtocol, call ? "a method call expected" : r.error(), tag);
  if (!r.at_end()) return error(kErrorProtocol, "text after the method call at column " + std::to_string(r.position() + 7), tag);
  return Command{*tag, std::move(call->text), std::move(call->args)};
}

std::optional<Reply> parse_reply(std::string_view line) {
  std::size_t bad = 0;
  if (line.size() < 7 || line.size() > kMaxLineChars || !printable(line, bad) || line[5] != ' ') return std::nullopt;
  const auto tag = parse_tag(line.substr(0, 5));
  if (!tag) return std::nullopt;
  Reply reply;
  reply.tag = *tag;
  const char marker = line[6];
  const std::string_view rest = line.size() > 7 ? line.substr(7) : std::string_view{};
  if (!rest.empty() && rest.front() != ' ') return std::nullopt;
  Reader r(rest);
  switch (marker) {
    case '&':
    case '%':
      if (!r.at_end()) return std::nullopt;
      reply.kind = marker == '&' ? ReplyKind::ack : ReplyKind::done;
      return reply;
    case '#': {
      auto items = r.terms(0);
      if (!items || items->empty()) return std::nullopt;
      reply.kind = ReplyKind::data;
      reply.data = std::move(*items);
      return reply;
    }
    case '!': {
      // Error(severity, code, method, "text"); method a name, a string, or left empty.
      auto e = r.term();
      if (!e || e->kind != Term::Kind::call || e->text != "Error" || !r.at_end() || e->args.size() != 4)
        return std::nullopt;
      const auto& a = e->args;
      if (a[0].kind != Term::Kind::number || a[1].kind != Term::Kind::number || a[3].kind != Term::Kind::string)
        return std::nullopt;
      const double severity = a[0].number, code = a[1].number;
      if (severity != std::floor(severity) || severity < 0 || severity > 9 || code != std::floor(code) || code < 0 ||
          code > 9999)
        return std::nullopt;
      reply.kind = ReplyKind::error;
      reply.error.severity = static_cast<int>(severity);
      reply.error.code = static_cast<int>(code);
      reply.error.method = a[2].kind == Term::Kind::number ? format_number(a[2].number) : a[2].text;
      reply.error.text = a[3].text;
      return reply;
    }
    default: return std::nullopt;
  }
}

std::string format_reply(const Reply& reply) {
  std::string out = format_tag(reply.tag) + " " + static_cast<char>(reply.kind);
  if (reply.kind == ReplyKind::data) out.append(" ").append(format_terms(reply.data));
  if (reply.kind == ReplyKind::error) {
    char head[32];
    std::snprintf(head, sizeof head, "Error(%d, %04d, ", reply.error.severity, reply.error.code);
    // The method goes unquoted when it is a name (GoTo), quoted otherwise ("" when none).
    const std::string& m = reply.error.method;
    bool name = !m.empty() && std::isalpha(static_cast<unsigned char>(m[0]));
    for (char c : m) name = name && (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.');
    // Appended piece by piece: GCC 12 at -O3 warns falsely (-Wrestrict) on "…" + std::string&&.
    out.append(" ").append(head);
    if (name) out.append(m);
    else out.append("\"").append(m).append("\"");
    out.append(", \"").append(reply.error.text).append("\")");
  }
  return out;
}

namespace {

struct ListedError {
  int code;
  int severity;
  const char* text;
};

// I++ DME 1.4.3 §8.2, in its order.
constexpr ListedError kErrorList[] = {
    {0, 0, "Buffer full"},
    {1, 2, "Illegal tag"},
    {2, 2, "No space at pos. 6"},
    {3, 2, "Reserved"},
    {4, 2, "Reserved"},
    {5, 2, "Reserved"},
    {6, 2, "Transaction aborted (Use ClearAllErrors To Continue)"},
    {7, 3, "Illegal character"},
    {8, 3, "Protocol error"},
    {500, 3, "Emergency stop"},
    {501, 3, "Unsupported command"},
    {502, 3, "Incorrect arguments"},
    {503, 9, "Controller communications failure"},
    {504, 1, "Argument out of range"},
    {505, 3, "Argument not recognized"},
    {506, 3, "Argument not supported"},
    {507, 3, "Illegal command"},
    {508, 3, "Bad context"},
    {509, 3, "Bad argument"},
    {510, 3, "Bad property"},
    {511, 3, "Error processing method"},
    {512, 1, "No daemons are active"},
    {513, 2, "Daemon does not exist"},
    {514, 2, "Use ClearAllErrors to continue"},
    {515, 2, "Daemon already exists"},
    {1000, 3, "Machine in error state"},
    {1001, 2, "Illegal touch"},
    {1002, 9, "Axis does not exist"},
    {1003, 2, "No touch"},
    {1004, 9, "Number of angles not supported on current device"},
    {1005, 3, "Error during home"},
    {1006, 2, "Surface not found"},
    {1007, 3, "Theta out of range"},
    {1008, 3, "Target position out of machine volume"},
    {1009, 3, "Air pressure out of range"},
    {1010, 2, "Vector has no norm"},
    {1011, 2, "Unable to move"},
    {1012, 2, "Bad lock combinations"},
    {1500, 3, "Failed to re-seat head"},
    {1501, 3, "Probe not armed"},
    {1502, 3, "Tool not found"},
    {1503, 3, "Tool not defined"},
    {2000, 3, "Tool not calibrated"},
    {2001, 2, "Head error excessive force"},
    {2002, 3, "Type of probe does not allow this operation"},
    {2500, 3, "Machine limit encountered [Move Out Of Limits]"},
    {2501, 3, "Axis not active"},
    {2502, 3, "Axis position error"},
    {2503, 9, "Scale read head failure"},
    {2504, 3, "Collision"},
    {2505, 2, "Specified angle out of range"},
    {2506, 2, "Part not aligned"},
};

const ListedError* listed(int code) {
  for (const ListedError& e : kErrorList)
    if (e.code == code) return &e;
  return nullptr;
}

}  // namespace

std::string error_text(int code) {
  const ListedError* e = listed(code);
  return e ? e->text : "Error " + std::to_string(code);
}

int default_severity(int code) {
  const ListedError* e = listed(code);
  return e ? e->severity : 3;
}

FaultKind fault_from_error(int code) {
  switch (code) {
    case kErrorEStop: return FaultKind::estop;
    case kErrorNoTouch:
    case kErrorSurfaceNotFound: return FaultKind::no_contact;
    case kErrorOutOfVolume: return FaultKind::soft_limit;
    case kErrorMachineLimit: return FaultKind::hard_limit;
    case kErrorCollision: return FaultKind::early_trigger;
    case kErrorTransactionAborted: return FaultKind::aborted;
    default: return FaultKind::protocol;
  }
}

}  // namespace cmm::hal::ippdme
