// cmm-sim's I++ DME server, in-process over loopback TCP: the exact lines of the contract the client
// driver relies on (sessions, refusals before acceptance, the error state, AbortE, e-stop, daemons,
// line framing, link faults) and PtMeas's radius-compensated points against the simulator's truth.
#include "sim/ippdme_server.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace cmm::sim {
namespace {

namespace ipp = hal::ippdme;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using Clock = std::chrono::steady_clock;

constexpr double kReadTimeoutS = 5;  // a line that does not come within this fails the test, never hangs it

// A blocking line client for the tests: send lines, read lines with a timeout.
class LineClient {
 public:
  explicit LineClient(int port) : fd_(::socket(AF_INET, SOCK_STREAM, 0)) {
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<std::uint16_t>(port));
    inet_pton(AF_INET, "127.0.0.1", &address.sin_addr);
    if (fd_ < 0 || ::connect(fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0)
      throw std::runtime_error("cannot connect to 127.0.0.1:" + std::to_string(port) + ": " + std::strerror(errno));
  }
  ~LineClient() { close(); }
  LineClient(const LineClient&) = delete;
  LineClient& operator=(const LineClient&) = delete;

  void close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }
  void send_raw(std::string_view bytes) {
    while (!bytes.empty()) {
      const ssize_t n = ::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL);
      if (n <= 0) throw std::runtime_error(std::string("send failed: ") + std::strerror(errno));
      bytes.remove_prefix(static_cast<std::size_t>(n));
    }
  }
  void send(std::string_view line) { send_raw(std::string(line) + "\r\n"); }

  // The next line without its CRLF; nullopt after the timeout or when the server has closed.
  std::optional<std::string> read_line(double timeout_s = kReadTimeoutS) {
    const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeout_s));
    for (;;) {
      if (const auto lf = buffer_.find('\n'); lf != std::string::npos) {
        std::string line = buffer_.substr(0, lf);
        buffer_.erase(0, lf + 1);
        if (!line.empty() && line.back() == '\r') line.pop_back();
        return line;
      }
      if (closed_) return std::nullopt;
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      if (left <= 0) return std::nullopt;
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left)) <= 0) continue;
      char chunk[4096];
      const ssize_t n = ::recv(fd_, chunk, sizeof chunk, 0);
      if (n <= 0) closed_ = true;
      else buffer_.append(chunk, static_cast<std::size_t>(n));
    }
  }
  bool closed_by_server(double timeout_s = kReadTimeoutS) {
    while (read_line(timeout_s)) {
    }
    return closed_;
  }

  // Sends `line` and reads until the transaction on `tag` (the line's own by default) ends: its `%`,
  // which follows an error too (I++ DME 1.4.3 §6.2.3); on E0000, which has none, the error. Returns
  // every line read meanwhile, other tags' too, in order.
  std::vector<std::string> exchange(const std::string& line, std::string tag = "") {
    send(line);
    return until_end(tag.empty() ? line.substr(0, 5) : tag);
  }
  std::vector<std::string> until_end(const std::string& tag) {
    std::vector<std::string> lines;
    for (;;) {
      const auto next = read_line();
      if (!next) {
        ADD_FAILURE() << "no end of transaction " << tag << " within " << kReadTimeoutS << " s; got "
                      << ::testing::PrintToString(lines);
        return lines;
      }
      lines.push_back(*next);
      const auto reply = ipp::parse_reply(*next);
      if (!reply || ipp::format_tag(reply->tag) != tag) continue;
      if (reply->kind == ipp::ReplyKind::done) return lines;
      if (reply->kind == ipp::ReplyKind::error && reply->tag == ipp::kServerTag) return lines;
    }
  }

 private:
  int fd_;
  std::string buffer_;
  bool closed_ = false;
};

// One machine, its server on a loopback port and the thread serving it.
struct Rig {
  explicit Rig(const nlohmann::json& config = nlohmann::json::object(), hal::ProtocolLog* log = nullptr,
               IppDmeOptions options = {})
      : machine(sim_config_from_json(config, CMMD_SOURCE_DIR)),
        server(machine, machine.config().faults, IppDmeEndpoint{"127.0.0.1", 0}, log, options),
        thread([this] { server.serve(); }) {}
  ~Rig() {
    server.shutdown();
    thread.join();
  }
  // A client with its session started.
  std::unique_ptr<LineClient> session() {
    auto client = std::make_unique<LineClient>(server.port());
    EXPECT_THAT(client->exchange("00001 StartSession()"), ElementsAre("00001 &", "00001 %"));
    return client;
  }

  SimulatedMachine machine;
  IppDmeServer server;
  std::thread thread;
};

// Homing takes no travel (it starts where it ends), and a long straight GoTo from there runs in wall
// time: 400 mm at 200 mm/s, 2.2 s of machine time.
nlohmann::json wall_time_config(double time_scale) {
  return {{"time_scale", time_scale}, {"home_position", {300, 400, 300}}, {"power_on_position", {300, 400, 300}}};
}
constexpr const char* kLongMove = "GoTo(Y(800))";

void wait_until_moving(const SimulatedMachine& machine) {
  const auto deadline = Clock::now() + std::chrono::seconds(5);
  while (!machine.status().moving && Clock::now() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  ASSERT_TRUE(machine.status().moving) << "the motion never started";
}

ipp::Reply parsed(const std::string& line) {
  const auto reply = ipp::parse_reply(line);
  if (!reply) throw std::runtime_error("not an I++ line: " + line);
  return *reply;
}

TEST(IppDmeServer, SessionsStartAndEnd) {
  Rig rig;
  LineClient c(rig.server.port());
  // §6.3.1: outside a session only StartSession and EndSession; a second StartSession is 0008.
  EXPECT_THAT(c.exchange("00001 IsHomed()"),
              ElementsAre("00001 ! Error(3, 0008, IsHomed, \"Protocol error: StartSession first\")", "00001 %"));
  EXPECT_THAT(c.exchange("E0001 GetErrStatusE()"),
              ElementsAre("E0001 ! Error(3, 0008, GetErrStatusE, \"Protocol error: StartSession first\")", "E0001 %"));
  // StartSession clears the error state that refusal entered.
  EXPECT_THAT(c.exchange("00002 StartSession()"), ElementsAre("00002 &", "00002 %"));
  EXPECT_THAT(c.exchange("00003 StartSession()"),
              ElementsAre("00003 ! Error(3, 0008, StartSession, \"Protocol error: a session is active; EndSession first\")",
                          "00003 %"));
  EXPECT_THAT(c.exchange("00004 ClearAllErrors()"), ElementsAre("00004 &", "00004 %"));
  EXPECT_THAT(c.exchange("00005 GetDMEVersion()"), ElementsAre("00005 &", "00005 # DMEVersion(\"1.4.3\")", "00005 %"));
  EXPECT_THAT(c.exchange("00006 IsHomed()"), ElementsAre("00006 &", "00006 # IsHomed(0)", "00006 %"));
  EXPECT_THAT(c.exchange("00007 EnumTools()"), ElementsAre("00007 &", "00007 # \"T1\"", "00007 # \"T2\"", "00007 %"));
  EXPECT_THAT(c.exchange("00008 EndSession()"), ElementsAre("00008 &", "00008 %"));
  EXPECT_THAT(c.exchange("00009 IsHomed()"),
              ElementsAre("00009 ! Error(3, 0008, IsHomed, \"Protocol error: StartSession first\")", "00009 %"));
  EXPECT_THAT(c.exchange("00010 StartSession()"), ElementsAre("00010 &", "00010 %"));
}

TEST(IppDmeServer, RefusesMalformedLinesWithoutAnAck) {
  Rig rig;
  auto c = rig.session();
  EXPECT_THAT(c->exchange("00002GetDMEVersion()"),
              ElementsAre("00002 ! Error(2, 0002, \"\", \"No space at pos. 6: no space after the tag\")", "00002 %"));
  EXPECT_THAT(c->exchange("0x003 IsHomed()", "E0000"),
              ElementsAre("E0000 ! Error(2, 0001, \"\", \"Illegal tag: a line starts with a tag 00001-99999 or E0001-E9999\")"));
  const auto syntax = c->exchange("00004 GoTo(X(1)");
  ASSERT_EQ(syntax.size(), 2u);
  EXPECT_THAT(syntax[0], HasSubstr("00004 ! Error(3, 0008, \"\", \"Protocol error: "));
  const auto control = c->exchange(std::string("00005 Is\x01Homed()"));
  ASSERT_EQ(control.size(), 2u);
  EXPECT_THAT(control[0], HasSubstr("00005 ! Error(3, 0007, \"\", \"Illegal character: character 1 at column 9"));
  EXPECT_THAT(c->exchange("00006 Fly(X(1))"), ElementsAre("00006 ! Error(3, 0501, Fly, \"Unsupported command\")", "00006 %"));
  // Each queue its own tags; E0000 is the server's.
  EXPECT_THAT(c->exchange("E0001 Home()"),
              ElementsAre("E0001 ! Error(2, 0001, Home, \"Illegal tag: Home takes a tag 00001-99999\")", "E0001 %"));
  EXPECT_THAT(c->exchange("00007 AbortE()"),
              ElementsAre("00007 ! Error(2, 0001, AbortE, \"Illegal tag: AbortE is a fast-queue command, its tag E0001-E9999\")",
                          "00007 %"));
  EXPECT_THAT(c->exchange("E0000 GetErrStatusE()"),
              ElementsAre("E0000 ! Error(2, 0001, GetErrStatusE, "
                          "\"Illegal tag: GetErrStatusE is a fast-queue command, its tag E0001-E9999\")"));
  // A stray CRLF asks nothing; ClearAllErrors restores service.
  c->send("");
  EXPECT_THAT(c->exchange("00008 ClearAllErrors()"), ElementsAre("00008 &", "00008 %"));
  EXPECT_THAT(c->exchange("00009 GetDMEVersion()"), ElementsAre("00009 &", "00009 # DMEVersion(\"1.4.3\")", "00009 %"));
}

TEST(IppDmeServer, TheTagOfAnOpenTransactionIsInUse) {
  Rig rig;
  auto c = rig.session();
  // The daemon's command is complete at once, but its reports carry its tag until it is stopped.
  EXPECT_THAT(c->exchange("E0001 OnMoveReportE(Time(1), X(), Y(), Z())"), ElementsAre("E0001 &", "E0001 %"));
  c->send("E0001 GetErrStatusE()");
  // No `%` here: it would read as the end of what runs on that tag.
  EXPECT_EQ(c->read_line(), "E0001 ! Error(2, 0001, GetErrStatusE, \"Illegal tag: E0001 is the tag of an open transaction\")");
  EXPECT_THAT(c->exchange("E0002 GetErrStatusE()"), ElementsAre("E0002 &", "E0002 # ErrStatus(1)", "E0002 %"));
  EXPECT_THAT(c->exchange("E0003 StopDaemon(E0001)"), ElementsAre("E0003 &", "E0003 %"));
  EXPECT_THAT(c->exchange("00002 ClearAllErrors()"), ElementsAre("00002 &", "00002 %"));
  EXPECT_THAT(c->exchange("E0001 GetErrStatusE()"), ElementsAre("E0001 &", "E0001 # ErrStatus(0)", "E0001 %"));
}

TEST(IppDmeServer, AfterAnErrorOnlyClearAllErrorsIsAccepted) {
  Rig rig;
  auto c = rig.session();
  // Motion before Home is 0507 "Illegal command", as NIST's server answers it.
  EXPECT_THAT(c->exchange("00002 GoTo(Z(300))"),
              ElementsAre("00002 &", "00002 ! Error(3, 0507, GoTo, \"Illegal command: home() first\")", "00002 %"));
  EXPECT_THAT(c->exchange("00003 ClearAllErrors()"), ElementsAre("00003 &", "00003 %"));
  EXPECT_THAT(c->exchange("00004 Home()"), ElementsAre("00004 &", "00004 %"));
  // An errored transaction is complete only with its `%` (§6.2.3's example).
  const auto far = c->exchange("00005 GoTo(X(800))");
  ASSERT_EQ(far.size(), 3u);
  EXPECT_THAT(far[1], HasSubstr("00005 ! Error(3, 1008, GoTo, \"Target position out of machine volume: move target (800.0000"));
  EXPECT_EQ(far[2], "00005 %");
  // §6.3.1.7's example: acknowledged, refused, complete.
  EXPECT_THAT(c->exchange("00006 Get(X())"),
              ElementsAre("00006 &", "00006 ! Error(2, 0514, Get, \"Use ClearAllErrors to continue\")", "00006 %"));
  EXPECT_THAT(c->exchange("00007 EndSession()"),
              ElementsAre("00007 &", "00007 ! Error(2, 0514, EndSession, \"Use ClearAllErrors to continue\")", "00007 %"));
  EXPECT_THAT(c->exchange("E0001 GetErrStatusE()"), ElementsAre("E0001 &", "E0001 # ErrStatus(1)", "E0001 %"));
  EXPECT_THAT(c->exchange("E0002 GetPropE(Tool.GoToPar.Speed())"),
              ElementsAre("E0002 &", "E0002 # Tool.GoToPar.Speed(200.000000000)", "E0002 %"));
  EXPECT_THAT(c->exchange("00008 ClearAllErrors()"), ElementsAre("00008 &", "00008 %"));
  EXPECT_THAT(c->exchange("00009 Get(X(), Y(), Z())"),
              ElementsAre("00009 &", "00009 # X(700.000000000), Y(900.000000000), Z(450.000000000)", "00009 %"));
  EXPECT_THAT(c->exchange("E0001 GetErrStatusE()"), ElementsAre("E0001 &", "E0001 # ErrStatus(0)", "E0001 %"));
  // An argument error is answered after the ack, and is an error like any other.
  EXPECT_THAT(c->exchange("00010 SetCoordSystem(MoveableMachineCsy)"),
              ElementsAre("00010 &",
                          "00010 ! Error(3, 0502, SetCoordSystem, "
                          "\"Incorrect arguments: SetCoordSystem takes MachineCsy or PartCsy\")",
                          "00010 %"));
}

TEST(IppDmeServer, AbortEStopsALongMoveAndKeepsThePosition) {
  Rig rig(wall_time_config(1));
  auto c = rig.session();
  EXPECT_THAT(c->exchange("00002 Home()"), ElementsAre("00002 &", "00002 %"));
  c->send(std::string("00003 ") + kLongMove);
  EXPECT_EQ(c->read_line(), "00003 &");
  c->send("00004 IsHomed()");  // queued behind the move
  EXPECT_EQ(c->read_line(), "00004 &");
  wait_until_moving(rig.machine);
  // §6.3.1.5 and its example: acknowledged, the running and the pending ones aborted, then its `%`.
  const std::string aborted = " \"Transaction aborted (Use ClearAllErrors To Continue)\")";
  EXPECT_THAT(c->exchange("E0001 AbortE()"),
              ElementsAre("E0001 &", "00003 ! Error(2, 0006, GoTo," + aborted, "00003 %",
                          "00004 ! Error(2, 0006, IsHomed," + aborted, "00004 %", "E0001 %"));
  EXPECT_THAT(c->exchange("00005 Get(Y())"),
              ElementsAre("00005 &", "00005 ! Error(2, 0514, Get, \"Use ClearAllErrors to continue\")", "00005 %"));
  EXPECT_THAT(c->exchange("00006 ClearAllErrors()"), ElementsAre("00006 &", "00006 %"));
  const auto where = c->exchange("00007 Get(Y())");
  ASSERT_EQ(where.size(), 3u);
  const double y = *ipp::number_of(parsed(where[1]).data, "Y");
  EXPECT_GT(y, 400);
  EXPECT_LT(y, 800);  // stopped on its way, not run to the end
  EXPECT_THAT(c->exchange("00008 IsHomed()"), ElementsAre("00008 &", "00008 # IsHomed(1)", "00008 %"));
}

TEST(IppDmeServer, ADisconnectStopsTheMotionAndTheNextClientIsServed) {
  Rig rig(wall_time_config(1));
  {
    auto c = rig.session();
    EXPECT_THAT(c->exchange("00002 Home()"), ElementsAre("00002 &", "00002 %"));
    c->send(std::string("00003 ") + kLongMove);
    EXPECT_EQ(c->read_line(), "00003 &");
    wait_until_moving(rig.machine);
  }
  auto next = rig.session();
  const auto where = next->exchange("00002 Get(Y())");  // runs once the stopped motion has ended
  ASSERT_EQ(where.size(), 3u);
  EXPECT_LT(*ipp::number_of(parsed(where[1]).data, "Y"), 800);
  EXPECT_THAT(next->exchange("00003 IsHomed()"), ElementsAre("00003 &", "00003 # IsHomed(1)", "00003 %"));
}

TEST(IppDmeServer, ASecondConnectionIsClosedAtOnce) {
  Rig rig;
  auto first = rig.session();
  LineClient second(rig.server.port());
  EXPECT_TRUE(second.closed_by_server());
  EXPECT_THAT(first->exchange("00002 IsHomed()"), ElementsAre("00002 &", "00002 # IsHomed(0)", "00002 %"));
}

TEST(IppDmeServer, AnOverLongLineIsRefusedOnceAndDiscarded) {
  Rig rig;
  auto c = rig.session();
  // Up to the limit a line is a line (this one a syntax error, not an over-long one).
  std::string longest = "00002 X(" + std::string(ipp::kMaxLineChars - 8, '1');
  ASSERT_EQ(longest.size(), ipp::kMaxLineChars);
  EXPECT_THAT(c->exchange(longest).at(0), HasSubstr("00002 ! Error(3, 0008, "));
  // One over: 0000 once, and what follows up to the LF, commands included, is discarded.
  c->send_raw("00003 " + std::string(ipp::kMaxLineChars, 'x'));
  c->send("00004 Home()");
  const std::string buffer_full = " ! Error(2, 0000, \"\", \"Buffer full: a line over 65536 characters, discarded\")";
  EXPECT_THAT(c->until_end("00003"), ElementsAre("00003" + buffer_full, "00003 %"));
  c->send_raw(std::string(3 * ipp::kMaxLineChars, 'y') + "\n");
  EXPECT_THAT(c->until_end("E0000"), ElementsAre("E0000" + buffer_full));
  EXPECT_THAT(c->exchange("00005 ClearAllErrors()"), ElementsAre("00005 &", "00005 %"));
  EXPECT_THAT(c->exchange("00006 IsHomed()"), ElementsAre("00006 &", "00006 # IsHomed(0)", "00006 %"));
}

TEST(IppDmeServer, AHalfLineRunsOnlyWhenItsLineEnds) {
  const auto log_file = std::filesystem::path(::testing::TempDir()) / ("ippdme-" + std::to_string(getpid()) + ".log");
  std::filesystem::remove(log_file);
  hal::ProtocolLog log(log_file.string());
  Rig rig(nlohmann::json::object(), &log);
  {
    auto c = rig.session();
    c->send_raw("00002 Hom");
    c->send_raw("e()\n");  // a bare LF ends a line too
    // Had the half line been taken for a line, its refusal would come before this.
    EXPECT_THAT(c->until_end("00002"), ElementsAre("00002 &", "00002 %"));
    EXPECT_THAT(c->exchange("00003 GoTo(Z(300))"), ElementsAre("00003 &", "00003 %"));
    c->send_raw("00004 GoTo(Z(100))");  // never ended: the client hangs up
  }
  auto next = rig.session();
  EXPECT_THAT(next->exchange("00002 Get(Z())"), ElementsAre("00002 &", "00002 # Z(300.000000000)", "00002 %"));
  std::ifstream in(log_file);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_THAT(text.str(), HasSubstr("-- dropped a half line of 18 characters: 00004 GoTo(Z(100))"));
  EXPECT_THAT(text.str(), HasSubstr("<- 00003 GoTo(Z(300))"));
  EXPECT_THAT(text.str(), HasSubstr("-> 00003 %"));
  std::filesystem::remove(log_file);
}

TEST(IppDmeServer, SetPropClampsWithAWarning) {
  Rig rig;
  auto c = rig.session();
  EXPECT_THAT(c->exchange("00002 GetProp(Tool.PtMeasPar.Speed(), Tool.PtMeasPar.Approach(), Tool.PtMeasPar.Search(), "
                          "Tool.PtMeasPar.Retract(), Tool.Name())"),
              ElementsAre("00002 &",
                          "00002 # Tool.PtMeasPar.Speed(5.000000000), Tool.PtMeasPar.Approach(2.000000000), "
                          "Tool.PtMeasPar.Search(5.000000000), Tool.PtMeasPar.Retract(1.000000000), Tool.Name(\"T1\")",
                          "00002 %"));
  EXPECT_THAT(c->exchange("00003 SetProp(Tool.PtMeasPar.Speed(50), Tool.PtMeasPar.Approach(3))"),
              ElementsAre("00003 &",
                          "00003 ! Error(1, 0504, SetProp, \"Tool.PtMeasPar.Speed 50 out of range: clamped to 20\")",
                          "00003 %"));
  EXPECT_THAT(c->exchange("00004 GetProp(Tool.PtMeasPar.Speed(), Tool.PtMeasPar.Approach())"),
              ElementsAre("00004 &", "00004 # Tool.PtMeasPar.Speed(20.000000000), Tool.PtMeasPar.Approach(3.000000000)",
                          "00004 %"));
  // An unknown property refuses the whole SetProp: nothing changes.
  const auto unknown = c->exchange("00005 SetProp(Tool.PtMeasPar.Speed(4), Tool.PtMeasPar.Colour(1))");
  ASSERT_EQ(unknown.size(), 3u);
  EXPECT_THAT(unknown[1], HasSubstr("00005 ! Error(3, 0502, SetProp, \"Incorrect arguments: no property Tool.PtMeasPar.Colour"));
  EXPECT_THAT(c->exchange("00006 ClearAllErrors()"), ElementsAre("00006 &", "00006 %"));
  EXPECT_THAT(c->exchange("00007 GetProp(Tool.PtMeasPar.Speed())"),
              ElementsAre("00007 &", "00007 # Tool.PtMeasPar.Speed(20.000000000)", "00007 %"));
  // A new session starts from the defaults.
  EXPECT_THAT(c->exchange("00008 EndSession()"), ElementsAre("00008 &", "00008 %"));
  EXPECT_THAT(c->exchange("00009 StartSession()"), ElementsAre("00009 &", "00009 %"));
  EXPECT_THAT(c->exchange("00010 GetProp(Tool.PtMeasPar.Speed())"),
              ElementsAre("00010 &", "00010 # Tool.PtMeasPar.Speed(5.000000000)", "00010 %"));
}

TEST(IppDmeServer, PtMeasReportsTheSurfacePointOfTheTruthsTouch) {
  constexpr double kSigma = 0.001;
  Rig rig(nlohmann::json{{"trigger_sigma_mm", kSigma}, {"seed", 42}});
  auto c = rig.session();
  EXPECT_THAT(c->exchange("00002 Home()"), ElementsAre("00002 &", "00002 %"));
  EXPECT_THAT(c->exchange("00003 GoTo(X(278), Y(353), Z(60))"), ElementsAre("00003 &", "00003 %"));
  EXPECT_THAT(c->exchange("00004 OnPtMeasReport(X(), Y(), Z(), IJK(), ER(), Clock())"), ElementsAre("00004 &", "00004 %"));
  // The block's top (z 41) at block (28, 28); the ball starts Approach + r above it.
  const auto top = c->exchange("00005 PtMeas(X(278), Y(353), Z(41), IJK(0, 0, 2))");
  ASSERT_EQ(top.size(), 3u);
  const ipp::Reply r = parsed(top[1]);
  ASSERT_EQ(r.kind, ipp::ReplyKind::data);
  const Vec3 p(*ipp::number_of(r.data, "X"), *ipp::number_of(r.data, "Y"), *ipp::number_of(r.data, "Z"));
  const Vec3 n = *ipp::vector_of(r.data, "IJK");
  const double er = *ipp::number_of(r.data, "ER");
  EXPECT_EQ(n, Vec3(0, 0, 1));
  EXPECT_EQ(er, 1.0);
  EXPECT_NEAR(p.z(), 41, 3 * kSigma);
  hal::ProbeMove same;
  same.start = Vec3(278, 353, 41 + 2 + 1);
  same.direction = -Vec3::UnitZ();
  same.max_travel_mm = 2 + 5;
  const Vec3 truth = *rig.machine.true_contact(same);
  EXPECT_LT((p + n * er - truth).norm(), 3 * kSigma);
  const double clock = *ipp::number_of(r.data, "Clock");
  EXPECT_GT(clock, 0);
  EXPECT_LT(clock, rig.machine.status().t_s);  // the retract came after the touch

  // A wall, sideways, in the order asked: the block's x = 250 side at mid-height.
  EXPECT_THAT(c->exchange("00006 OnPtMeasReport(IJK(), X(), ER())"), ElementsAre("00006 &", "00006 %"));
  EXPECT_THAT(c->exchange("00007 GoTo(X(240), Y(353), Z(60))"), ElementsAre("00007 &", "00007 %"));
  EXPECT_THAT(c->exchange("00008 GoTo(Z(20))"), ElementsAre("00008 &", "00008 %"));
  const auto wall = c->exchange("00009 PtMeas(X(250), Y(353), Z(20), IJK(-1, 0, 0))");
  ASSERT_EQ(wall.size(), 3u);
  EXPECT_THAT(wall[1], ::testing::StartsWith("00009 # IJK(-1.000000000, 0.000000000, 0.000000000), X(2"));
  EXPECT_THAT(wall[1], ::testing::EndsWith(", ER(1.000000000)"));
  same.start = Vec3(250 - 3, 353, 20);
  same.direction = Vec3::UnitX();
  EXPECT_NEAR(*ipp::number_of(parsed(wall[1]).data, "X") - 1, rig.machine.true_contact(same)->x(), 3 * kSigma);
}

TEST(IppDmeServer, PtMeasFaults) {
  Rig rig;
  auto c = rig.session();
  EXPECT_THAT(c->exchange("00002 Home()"), ElementsAre("00002 &", "00002 %"));
  const auto air = c->exchange("00003 PtMeas(X(100), Y(100), Z(100), IJK(0, 0, 1))");
  ASSERT_EQ(air.size(), 3u);
  EXPECT_THAT(air[1], HasSubstr("00003 ! Error(2, 1003, PtMeas, \"No touch: no trigger within 7.000000 mm"));
  EXPECT_THAT(c->exchange("00004 ClearAllErrors()"), ElementsAre("00004 &", "00004 %"));
  // Its start inside the block: the probe triggers on the way there.
  EXPECT_THAT(c->exchange("00005 GoTo(X(278), Y(353), Z(60))"), ElementsAre("00005 &", "00005 %"));
  const auto inside = c->exchange("00006 PtMeas(X(278), Y(353), Z(20), IJK(0, 0, 1))");
  ASSERT_EQ(inside.size(), 3u);
  EXPECT_THAT(inside[1], HasSubstr("00006 ! Error(3, 2504, PtMeas, \"Collision: the probe triggered on the way to the search start"));
  EXPECT_THAT(c->exchange("00007 ClearAllErrors()"), ElementsAre("00007 &", "00007 %"));
  const auto no_normal = c->exchange("00008 PtMeas(X(278), Y(353), Z(41))");
  EXPECT_THAT(no_normal.at(1), HasSubstr("00008 ! Error(3, 0502, PtMeas, \"Incorrect arguments: PtMeas needs IJK"));
}

TEST(IppDmeServer, AnEStopSendsTheEventFirst) {
  Rig rig(nlohmann::json{{"faults", {{"estop_at_s", 0.5}}}});  // homing takes some 3.5 s of machine time
  auto c = rig.session();
  EXPECT_THAT(c->exchange("00002 Home()"), ElementsAre("00002 &", "E0000 ! Error(3, 0500, Home, \"Emergency stop\")",
                                                       "00002 ! Error(3, 0500, Home, \"Emergency stop\")", "00002 %"));
  EXPECT_TRUE(rig.machine.status().estop);
  EXPECT_THAT(c->exchange("00003 Home()"),
              ElementsAre("00003 &", "00003 ! Error(2, 0514, Home, \"Use ClearAllErrors to continue\")", "00003 %"));
  EXPECT_THAT(c->exchange("00004 ClearAllErrors()"), ElementsAre("00004 &", "00004 %"));
  EXPECT_FALSE(rig.machine.status().estop);
  EXPECT_THAT(c->exchange("00005 IsHomed()"), ElementsAre("00005 &", "00005 # IsHomed(0)", "00005 %"));
  EXPECT_THAT(c->exchange("00006 Home()"), ElementsAre("00006 &", "00006 %"));
}

TEST(IppDmeServer, OnMoveReportEStreamsDuringAMove) {
  Rig rig(wall_time_config(4));
  auto c = rig.session();
  EXPECT_THAT(c->exchange("00002 Home()"), ElementsAre("00002 &", "00002 %"));
  EXPECT_THAT(c->exchange("E0001 OnMoveReportE(Time(0.1), Y(), X())"), ElementsAre("E0001 &", "E0001 %"));
  const auto lines = c->exchange(std::string("00003 ") + kLongMove);  // 0.55 s of wall time
  std::vector<double> ys;
  for (const std::string& line : lines) {
    const ipp::Reply r = parsed(line);
    if (ipp::format_tag(r.tag) != "E0001") continue;
    ASSERT_EQ(r.kind, ipp::ReplyKind::data) << line;
    ASSERT_EQ(r.data.size(), 2u);
    EXPECT_EQ(r.data[0].text, "Y");
    EXPECT_EQ(*ipp::number_of(r.data, "X"), 300);
    ys.push_back(*ipp::number_of(r.data, "Y"));
  }
  EXPECT_GE(ys.size(), 3u) << "reports every 0.1 s during a 0.55 s move";
  EXPECT_TRUE(std::is_sorted(ys.begin(), ys.end()));
  // One more report when the motion has ended, at its end.
  while (ys.empty() || ys.back() < 800 - 1e-9) {
    const auto line = c->read_line();
    ASSERT_TRUE(line) << "no report of the motion's end";
    ys.push_back(*ipp::number_of(parsed(*line).data, "Y"));
  }
  EXPECT_THAT(c->exchange("E0002 StopDaemon(E0001)"), ElementsAre("E0002 &", "E0002 %"));
  EXPECT_THAT(c->exchange("E0003 OnMoveReportE(Dis(1))"), ElementsAre("E0003 &", "E0003 %"));
  EXPECT_THAT(c->exchange("E0005 StopAllDaemons()"), ElementsAre("E0005 &", "E0005 %"));
}

// §6.3.2.7 as NIST's server checks it: Time ≥ 0.1 (at most 10 reports a second), Dis > 0, and one
// daemon at a time; the stop commands' errors from §6.3.1.3-4.
TEST(IppDmeServer, OnMoveReportEKeepsToTheSpecsLimits) {
  Rig rig(wall_time_config(4));
  auto c = rig.session();
  EXPECT_THAT(c->exchange("E0001 OnMoveReportE(Time(0.05), X(), Y(), Z())"),
              ElementsAre("E0001 &",
                          "E0001 ! Error(3, 0510, OnMoveReportE, "
                          "\"Bad property: Time(0.05): at least 0.1 s, at most 10 reports a second\")",
                          "E0001 %"));
  EXPECT_THAT(c->exchange("00002 ClearAllErrors()"), ElementsAre("00002 &", "00002 %"));
  for (const char* dis : {"Dis(0)", "Dis(-1)"}) {
    const auto refused = c->exchange(std::string("E0002 OnMoveReportE(") + dis + ", X())");
    ASSERT_EQ(refused.size(), 3u);
    EXPECT_THAT(refused[1], HasSubstr("E0002 ! Error(3, 0510, OnMoveReportE, \"Bad property: " + std::string(dis)));
    EXPECT_THAT(c->exchange("00003 ClearAllErrors()"), ElementsAre("00003 &", "00003 %"));
  }
  // A second daemon is refused, the first keeps running.
  EXPECT_THAT(c->exchange("E0003 OnMoveReportE(Dis(0.01), Y())"), ElementsAre("E0003 &", "E0003 %"));
  EXPECT_THAT(c->exchange("E0004 OnMoveReportE(Time(1), Z())"),
              ElementsAre("E0004 &",
                          "E0004 ! Error(2, 0515, OnMoveReportE, "
                          "\"Daemon already exists: a daemon runs on E0003; StopDaemon or StopAllDaemons first\")",
                          "E0004 %"));
  EXPECT_THAT(c->exchange("00004 ClearAllErrors()"), ElementsAre("00004 &", "00004 %"));
  EXPECT_EQ(c->exchange("00005 Home()").back(), "00005 %");
  // Every 0.01 mm asks for a report every few µs of a 0.55 s move: at most 10 a second, and the
  // one as the motion ends.
  const auto lines = c->exchange(std::string("00006 ") + kLongMove);
  const auto reports = std::count_if(lines.begin(), lines.end(), [](const std::string& l) { return l.starts_with("E0003 #"); });
  EXPECT_GE(reports, 2);
  EXPECT_LE(reports, 8);
  EXPECT_THAT(c->exchange("E0005 StopDaemon(E0004)"),
              ElementsAre("E0005 &", "E0005 ! Error(2, 0513, StopDaemon, \"Daemon does not exist: no daemon runs on tag E0004\")",
                          "E0005 %"));
  EXPECT_THAT(c->exchange("00007 ClearAllErrors()"), ElementsAre("00007 &", "00007 %"));
  EXPECT_THAT(c->exchange("E0006 StopAllDaemons()"), ElementsAre("E0006 &", "E0006 %"));
  // None left: a warning, which needs no ClearAllErrors.
  EXPECT_THAT(c->exchange("E0007 StopAllDaemons()"),
              ElementsAre("E0007 &", "E0007 ! Error(1, 0512, StopAllDaemons, \"No daemons are active\")", "E0007 %"));
  EXPECT_THAT(c->exchange("00008 IsHomed()"), ElementsAre("00008 &", "00008 # IsHomed(1)", "00008 %"));
}

TEST(IppDmeServer, ChangeToolOfAnUnknownToolIs1502) {
  Rig rig;
  auto c = rig.session();
  EXPECT_THAT(c->exchange("00002 ChangeTool(\"Probe9\")"),
              ElementsAre("00002 &", "00002 ! Error(3, 1502, ChangeTool, \"Tool not found: no tool Probe9 (EnumTools lists them)\")",
                          "00002 %"));
  EXPECT_THAT(c->exchange("00003 ClearAllErrors()"), ElementsAre("00003 &", "00003 %"));
  EXPECT_THAT(c->exchange("00004 ChangeTool(\"T2\")"), ElementsAre("00004 &", "00004 %"));
}

// §6.2.5: a severity ≥ 2 error aborts the transactions queued behind it. By default each is answered
// 0006 and `%` (§6.3.1.5); with PendingOnError::drop, as NIST's server, none is answered at all.
void queue_behind_a_failing_goto(LineClient& c) {
  EXPECT_THAT(c.exchange("00002 Home()"), ElementsAre("00002 &", "00002 %"));
  c.send(std::string("00003 ") + kLongMove);  // 0.55 s: the rest queue behind it
  c.send("00004 GoTo(X(800))");
  c.send("00005 IsHomed()");
  c.send("00006 Get(X())");
  for (const char* ack : {"00003 &", "00004 &", "00005 &", "00006 &"}) EXPECT_EQ(c.read_line(), ack);
  EXPECT_EQ(c.read_line(), "00003 %");
  const auto far = c.until_end("00004");
  ASSERT_EQ(far.size(), 2u);
  EXPECT_THAT(far[0], HasSubstr("00004 ! Error(3, 1008, GoTo, "));
}

TEST(IppDmeServer, TransactionsPendingBehindAnErrorAreAnswered0006) {
  Rig rig(wall_time_config(4));
  auto c = rig.session();
  queue_behind_a_failing_goto(*c);
  const std::string aborted = " \"Transaction aborted (Use ClearAllErrors To Continue)\")";
  EXPECT_THAT(c->until_end("00006"), ElementsAre("00005 ! Error(2, 0006, IsHomed," + aborted, "00005 %",
                                                 "00006 ! Error(2, 0006, Get," + aborted, "00006 %"));
  EXPECT_THAT(c->exchange("00007 ClearAllErrors()"), ElementsAre("00007 &", "00007 %"));
}

TEST(IppDmeServer, TransactionsPendingBehindAnErrorAreDroppedLikeNists) {
  Rig rig(wall_time_config(4), nullptr, IppDmeOptions{PendingOnError::drop});
  auto c = rig.session();
  queue_behind_a_failing_goto(*c);
  // Nothing on 00005 or 00006: the next lines are the status command's.
  EXPECT_THAT(c->exchange("E0001 GetErrStatusE()"), ElementsAre("E0001 &", "E0001 # ErrStatus(1)", "E0001 %"));
  EXPECT_THAT(c->exchange("00007 ClearAllErrors()"), ElementsAre("00007 &", "00007 %"));
  EXPECT_THAT(c->exchange("00005 IsHomed()"), ElementsAre("00005 &", "00005 # IsHomed(1)", "00005 %"));  // its tag is free
}

TEST(IppDmeServer, DropLinkAfterCommandsLosesTheNextOne) {
  Rig rig(nlohmann::json{{"faults", {{"drop_link_after_commands", 1}}}});
  {
    auto c = rig.session();
    EXPECT_THAT(c->exchange("00002 Home()"), ElementsAre("00002 &", "00002 %"));  // command 1
    c->send("00003 GoTo(Z(300))");                                                  // command 2: lost
    EXPECT_TRUE(c->closed_by_server());
  }
  auto next = rig.session();
  EXPECT_THAT(next->exchange("00002 Get(Z())"), ElementsAre("00002 &", "00002 # Z(450.000000000)", "00002 %"));
  EXPECT_THAT(next->exchange("00003 GoTo(Z(300))"), ElementsAre("00003 &", "00003 %"));  // once only
}

TEST(IppDmeServer, CorruptReplyGarblesThatCommandsLastLine) {
  Rig rig(nlohmann::json{{"faults", {{"corrupt_reply_at_command", 1}}}});
  auto c = rig.session();
  c->send("00002 Home()");
  EXPECT_EQ(c->read_line(), "00002 &");
  const auto garbled = c->read_line();
  ASSERT_TRUE(garbled);
  EXPECT_EQ(*garbled, "00002 ?");
  EXPECT_FALSE(ipp::parse_reply(*garbled));
  EXPECT_THAT(c->exchange("00003 IsHomed()"), ElementsAre("00003 &", "00003 # IsHomed(1)", "00003 %"));
}

// The delay holds back what the machine does (as on the Grbl and Modbus sides), not a session's
// set-up or a query: a client's connect works, its motion times out.
TEST(IppDmeServer, ReplyDelayHoldsBackTheCommandsThatChangeTheMachine) {
  Rig rig(nlohmann::json{{"faults", {{"reply_delay_s", 0.3}}}});
  auto c = rig.session();
  auto sent = Clock::now();
  EXPECT_THAT(c->exchange("00002 IsHomed()"), ElementsAre("00002 &", "00002 # IsHomed(0)", "00002 %"));
  EXPECT_LT(Clock::now() - sent, std::chrono::milliseconds(300));
  sent = Clock::now();
  c->send("00003 Home()");
  c->send("E0001 GetErrStatusE()");
  // The fast queue overtakes the delayed command, ack included.
  EXPECT_EQ(c->read_line(), "E0001 &");
  EXPECT_THAT(c->until_end("00003"), ElementsAre("E0001 # ErrStatus(0)", "E0001 %", "00003 &", "00003 %"));
  EXPECT_GE(Clock::now() - sent, std::chrono::milliseconds(300));
}

}  // namespace
}  // namespace cmm::sim
