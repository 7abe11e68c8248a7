// A station's cost of being on a fleet's broker: the real cmmd (in-process simulator, virtual
// clock, so touches are CPU-bound and any overhead shows) runs the same job with its MQTT link off
// and on, in one run, while 19 other stations' status, progress and job states and a dashboard
// reading cmmd/# go through the same mosquitto. The figure is the time per touch, on against off;
// where the difference goes (the job thread's own work, its wait for a core, the broker) is
// measured beside it. docs/PERFORMANCE.md has the runs.
#include <benchmark/benchmark.h>

#include <fcntl.h>
#include <sched.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "daemon/client/mqtt_client.hpp"
#include "daemon/client/rpc_client.hpp"
#include "hal/utc_time.hpp"
#include "tests/integration/broker_process.hpp"
#include "tests/integration/cmmd_instance.hpp"

namespace {

using namespace cmm;
using nlohmann::json;
using Clock = std::chrono::steady_clock;
using daemon::MqttClient;
using daemon::MqttMessage;

constexpr int kOtherStations = 19;
constexpr double kProgressPeriodS = 0.2;  // the other stations' progress_interval_s
constexpr int kProgressPerStatus = 5;     // a status every 1 s
constexpr int kProgressPerJob = 25;       // a job every 5 s: its states probing, done and result
// The job: submit_quick_job's (the sample scan, the plate measured first) at a denser spacing, for
// 5,440 touches: at ~0.1 ms a touch that is half a second of probing, so the timer's and the
// scheduler's jitter stay well under 1 %. --spacing=MM and --rounds=N change them.
double g_spacing_mm = 0.25;
int g_rounds = 12;
// --pin: this process, mosquitto and the fleet on core 1, each cmmd on core 0. The station then
// has a core of its own, as it would with the broker and the dashboards on other hosts, and what
// is left of the difference is cmmd's own work (its job thread's and its MQTT thread's).
bool g_pin = false;

std::string password_of(const std::string& user) { return user + "-pw"; }

double seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

// The 19 other stations, each an MQTT client under its own user as the documented ACL wants, and
// a dashboard that reads everything. One thread publishes for all of them, each station's slot
// spread over the 0.2 s period so that the broker sees an even stream rather than bursts of 19.
class FleetTraffic {
 public:
  explicit FleetTraffic(int port) {
    for (int i = 1; i <= kOtherStations; ++i) {
      char name[8];
      std::snprintf(name, sizeof name, "s%02d", i);
      stations_.push_back({name, client_for(port, name, {})});
      stations_.back().client->start();
    }
    daemon::MqttCallbacks dashboard;
    dashboard.connected = [this] { dashboard_->subscribe("cmmd/#", 1); };
    dashboard.message = [this](const MqttMessage& m) {
      ++received_;
      if (m.topic.starts_with("cmmd/bench")) ++received_bench_;
    };
    dashboard_ = client_for(port, "dashboard", std::move(dashboard));
    dashboard_->start();  // not before dashboard_ is set: its connected callback uses it
    const auto deadline = Clock::now() + std::chrono::seconds(10);
    auto all_up = [this] {
      if (!dashboard_->connected()) return false;
      for (const Station& s : stations_)
        if (!s.client->connected()) return false;
      return true;
    };
    while (!all_up()) {
      if (Clock::now() > deadline) throw std::runtime_error("the fleet's clients did not connect within 10 s");
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    thread_ = std::thread([this] { publish_loop(); });
  }
  ~FleetTraffic() {
    stopping_ = true;
    thread_.join();
    for (Station& s : stations_) s.client->stop();
    dashboard_->stop();
  }

  std::uint64_t published() const { return published_; }         // by the 19
  std::uint64_t received() const { return received_; }           // by the dashboard, all stations
  std::uint64_t received_bench() const { return received_bench_; }  // of those, cmmd's

 private:
  struct Station {
    std::string name;
    std::unique_ptr<MqttClient> client;
    int job = 1, done = 0, progress_sent = 0;
  };

  static std::unique_ptr<MqttClient> client_for(int port, const std::string& user, daemon::MqttCallbacks callbacks) {
    daemon::MqttConnect connect;
    connect.host = "127.0.0.1";
    connect.port = port;
    connect.client_id = "fleet-bench-" + user;
    connect.username = user;
    connect.password = password_of(user);
    if (user != "dashboard") {  // a station's last will, as cmmd sets it
      MqttMessage will;
      will.topic = "cmmd/" + user + "/status";
      will.payload = json{{"station", user}, {"online", false}}.dump();
      will.qos = 1;
      will.retain = true;
      connect.will = will;
    }
    return std::make_unique<MqttClient>(std::move(connect), std::move(callbacks));
  }

  void publish(Station& s, const std::string& topic, const json& payload, int qos, bool retain) {
    MqttMessage m;
    m.topic = topic;
    m.payload = payload.dump();
    m.qos = qos;
    m.retain = retain;
    s.client->publish(m);
    ++published_;
  }

  // What cmmd's MqttStation would send for a station running 5 s jobs of 25 progress steps.
  void tick(Station& s) {
    const std::string base = "cmmd/" + s.name + "/";
    const std::string job = base + "jobs/" + std::to_string(s.job) + "/";
    const auto state = [&](const char* name) {
      return json{{"job", s.job}, {"state", name}, {"reason", ""}, {"station", s.name}, {"time", hal::utc_now()}};
    };
    if (s.done == 0) publish(s, job + "state", state("probing"), 1, true);
    ++s.done;
    publish(s, job + "progress",
            {{"job", s.job}, {"phase", "probing"}, {"done", s.done}, {"total", kProgressPerJob},
             {"eta_s", (kProgressPerJob - s.done) * kProgressPeriodS}},
            0, false);
    if (++s.progress_sent % kProgressPerStatus == 0)
      publish(s, base + "status",
              {{"station", s.name}, {"online", true}, {"version", "bench"},
               {"machine", {{"lifecycle", "ready"}, {"link", "up"}, {"fault", nullptr}}},
               {"job", {{"id", s.job}, {"state", "probing"}}}, {"updated", hal::utc_now()}},
              1, true);
    if (s.done == kProgressPerJob) {
      publish(s, job + "state", state("done"), 1, true);
      publish(s, job + "result", state("done"), 1, true);
      ++s.job;
      s.done = 0;
    }
  }

  void publish_loop() {
    const auto slot =
        std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(kProgressPeriodS / kOtherStations));
    auto next = Clock::now();
    for (std::size_t i = 0; !stopping_; i = (i + 1) % stations_.size()) {
      std::this_thread::sleep_until(next);
      tick(stations_[i]);
      next += slot;
    }
  }

  std::vector<Station> stations_;
  std::unique_ptr<MqttClient> dashboard_;
  std::atomic<std::uint64_t> published_{0}, received_{0}, received_bench_{0};
  std::atomic<bool> stopping_{false};
  std::thread thread_;
};

// The station under test in three configurations, each its own cmmd, all with the same cmmd.json
// but for the mqtt block's enabled and progress_interval_s, and the station's name (its broker
// user and client id: two cmmd with one id would throw each other off the broker). Off; on with
// job.progress at the shortest interval cmmd.json allows (0.1 s; each touch published costs
// +14 to +24 %, docs/PERFORMANCE.md, which is why there is a floor); on with the
// default interval (1 s).
struct Variant {
  const char* name;
  const char* station;
  bool mqtt;
  double progress_interval_s;
};
constexpr Variant kVariants[] = {
    {"off", "bench0", false, 1}, {"on, progress 0.1 s", "bench1", true, 0.1}, {"on, progress 1 s", "bench2", true, 1}};
constexpr int kVariantCount = 3;

json station_config(const Variant& v, int broker_port) {
  return {{"station", v.station},
          {"mqtt", {{"enabled", v.mqtt}, {"broker", "127.0.0.1"}, {"port", broker_port}, {"username", v.station},
                    {"password", password_of(v.station)}, {"progress_interval_s", v.progress_interval_s}}}};
}

struct JobSample {
  int touches = 0;
  double probing_s = 0;   // as the job's subscriber saw it: job.state probing to the job.progress with every touch made
  double journal_s = 0;   // cmmd's own clock: the touch journal's creation to its last write (4 ms granules on tmpfs)
  double broker_msgs_per_s = 0;  // what the dashboard received meanwhile, all stations
  // Where the probing's time went (the kernel's schedstat): the job thread on a core and waiting
  // for one, all of cmmd's threads, mosquitto, and this process (fleet, dashboard, the subscriber).
  double job_run_s = 0, job_wait_s = 0, cmmd_run_s = 0, broker_run_s = 0, bench_run_s = 0;
  double per_touch_s() const { return probing_s / touches; }
};

// The job's probing as cmmd's job thread saw it: it creates touches.jsonl right after it announces
// probing and appends (and fsyncs) each touch, so birth to last change is every touch made.
double journal_span_s(const std::filesystem::path& file) {
  struct statx stx {};
  if (statx(AT_FDCWD, file.c_str(), 0, STATX_BTIME | STATX_MTIME, &stx) != 0 || !(stx.stx_mask & STATX_BTIME))
    throw std::runtime_error("no birth time for " + file.string());
  auto ns = [](const statx_timestamp& t) { return static_cast<double>(t.tv_sec) * 1e9 + t.tv_nsec; };
  return (ns(stx.stx_mtime) - ns(stx.stx_btime)) * 1e-9;
}

// Each thread's time on a core and waiting for one (ns), from /proc/<pid>/task/*/schedstat.
struct ThreadTimes {
  double run = 0, wait = 0;
};
std::map<int, ThreadTimes> thread_times(int pid) {
  std::map<int, ThreadTimes> out;
  std::error_code ec;
  for (const auto& task : std::filesystem::directory_iterator("/proc/" + std::to_string(pid) + "/task", ec)) {
    std::ifstream in(task.path() / "schedstat");
    ThreadTimes t;
    if (in >> t.run >> t.wait) out[std::stoi(task.path().filename().string())] = t;
  }
  return out;
}
double total_run_ns(const std::map<int, ThreadTimes>& before, const std::map<int, ThreadTimes>& after) {
  double sum = 0;
  for (const auto& [tid, t] : after) sum += t.run - (before.contains(tid) ? before.at(tid).run : 0);
  return sum;
}

// The broker's pid: BrokerProcess keeps its child to itself, so it is found by its config file.
int pid_running(const std::string& config) {
  for (const auto& entry : std::filesystem::directory_iterator("/proc")) {
    const std::string name = entry.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream in(entry.path() / "cmdline");
    std::string cmdline((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (cmdline.find(config) != std::string::npos && cmdline.starts_with("/usr/sbin/mosquitto")) return std::stoi(name);
  }
  throw std::runtime_error("no mosquitto running " + config);
}

struct Station {
  std::unique_ptr<testing::CmmdInstance> cmmd;
  std::optional<daemon::RpcClient> client;
};

// The whole run: the broker, the fleet, the three cmmd, then the jobs in rounds.
class Session {
 public:
  explicit Session(int rounds) {
    std::map<std::string, std::string> users = {{"dashboard", password_of("dashboard")}};
    for (const Variant& v : kVariants) users[v.station] = password_of(v.station);
    for (int i = 1; i <= kOtherStations; ++i) {
      char name[8];
      std::snprintf(name, sizeof name, "s%02d", i);
      users[name] = password_of(name);
    }
    // The documented ACL and a user per station, as a fleet runs it: the broker checks every message.
    broker_ = std::make_unique<testing::BrokerProcess>(folder_ / "broker", users);
    broker_->start();
    broker_pid_ = pid_running((folder_ / "broker" / "mosquitto.conf").string());
    fleet_ = std::make_unique<FleetTraffic>(broker_->port());
    model_ = testing::sample_scan(folder_ / "scan");
    registration_ = testing::sample_measure_plate(folder_ / "scan");
    for (int v = 0; v < kVariantCount; ++v) {
      Station& s = stations_[v];
      s.cmmd = std::make_unique<testing::CmmdInstance>(folder_ / kVariants[v].station, testing::sample_sim_block(),
                                                       station_config(kVariants[v], broker_->port()));
      s.cmmd->start(g_pin ? std::vector<std::string>{"/usr/bin/taskset", "-c", "0"} : std::vector<std::string>{});
      s.client.emplace(s.cmmd->client());
      s.client->call("server.subscribe", {{"topics", {"job"}}});
    }
    // A first job on each, not counted: the model's first load and whatever warms up.
    for (int v = 0; v < kVariantCount; ++v) run_job(v);
    if (fleet_->received_bench() == 0) throw std::runtime_error("the dashboard saw nothing of cmmd's station");
    const auto start = Clock::now();
    const std::uint64_t published0 = fleet_->published();
    // Rounds in mirrored order (0 1 2, 2 1 0, ...) so that a drift over the run, the VM's
    // neighbours or the broker's growing retained store, falls on every variant alike.
    for (int r = 0; r < rounds; ++r)
      for (int k = 0; k < kVariantCount; ++k) {
        const int v = r % 2 == 0 ? k : kVariantCount - 1 - k;
        const JobSample s = run_job(v);
        samples_[v].push_back(s);
        const double us = 1e6 / s.touches;
        std::fprintf(stderr,
                     "round %d %-19s %d touches, %.3f s (journal %.3f s): %6.2f us/touch; per touch: job thread "
                     "%5.1f us run %5.1f us waiting, cmmd %5.1f us, mosquitto %4.1f us, bench %4.1f us; %5.0f msg/s\n",
                     r + 1, kVariants[v].name, s.touches, s.probing_s, s.journal_s, s.per_touch_s() * 1e6,
                     s.job_run_s * us, s.job_wait_s * us, s.cmmd_run_s * us, s.broker_run_s * us, s.bench_run_s * us,
                     s.broker_msgs_per_s);
      }
    fleet_msgs_per_s_ = static_cast<double>(fleet_->published() - published0) / seconds(Clock::now() - start);
  }
  ~Session() {
    for (Station& s : stations_) {
      s.client.reset();
      s.cmmd.reset();
    }
    fleet_.reset();
    broker_.reset();
  }

  const std::vector<JobSample>& samples(int variant) const { return samples_[variant]; }
  double fleet_msgs_per_s() const { return fleet_msgs_per_s_; }

 private:
  JobSample run_job(int variant) {
    daemon::RpcClient& client = *stations_[variant].client;
    const int id = testing::submit_job(client, model_, {{"spacing_mm", g_spacing_mm}, {"registration", registration_}});
    JobSample sample;
    std::optional<Clock::time_point> probing, all_touched;
    std::uint64_t received0 = 0;
    const int cmmd_pid = stations_[variant].cmmd->process().pid();
    std::map<int, ThreadTimes> cmmd0, broker0, bench0;
    const auto deadline = Clock::now() + std::chrono::seconds(120);
    for (;;) {
      const double left = seconds(deadline - Clock::now());
      if (left <= 0) throw std::runtime_error("job " + std::to_string(id) + " did not end within 120 s");
      const std::optional<json> n = client.wait_notification(left);
      if (!n) continue;
      const auto now = Clock::now();
      const json& p = n->at("params");
      if (p.value("job", -1) != id) continue;
      const std::string method = n->at("method");
      if (method == "job.state") {
        const std::string state = p.at("state");
        if (state == "probing") {
          probing = now;
          received0 = fleet_->received();
          cmmd0 = thread_times(cmmd_pid);
          broker0 = thread_times(broker_pid_);
          bench0 = thread_times(getpid());
        } else if (state == "done") {
          if (!probing || !all_touched)
            throw std::runtime_error("job " + std::to_string(id) + " done without its probing seen");
          sample.journal_s = journal_span_s(stations_[variant].cmmd->job_folder(id) / "touches.jsonl");
          return sample;
        } else if (state == "failed" || state == "cancelled" || state == "paused" || state == "interrupted") {
          throw std::runtime_error("job " + std::to_string(id) + " " + state + ": " + p.dump());
        }
      } else if (method == "job.touch" && probing) {
        ++sample.touches;
      } else if (method == "job.progress" && probing && !all_touched && p.value("phase", "") == "probing" &&
                 p.value("done", 0) >= p.value("total", 1)) {
        all_touched = now;
        sample.probing_s = seconds(now - *probing);
        sample.broker_msgs_per_s = static_cast<double>(fleet_->received() - received0) / sample.probing_s;
        const std::map<int, ThreadTimes> cmmd1 = thread_times(cmmd_pid);
        for (const auto& [tid, t] : cmmd1)  // the job's thread: the one that ran longest meanwhile
          if (cmmd0.contains(tid) && t.run - cmmd0[tid].run > sample.job_run_s * 1e9) {
            sample.job_run_s = (t.run - cmmd0[tid].run) * 1e-9;
            sample.job_wait_s = (t.wait - cmmd0[tid].wait) * 1e-9;
          }
        sample.cmmd_run_s = total_run_ns(cmmd0, cmmd1) * 1e-9;
        sample.broker_run_s = total_run_ns(broker0, thread_times(broker_pid_)) * 1e-9;
        sample.bench_run_s = total_run_ns(bench0, thread_times(getpid())) * 1e-9;
        if (sample.touches != p.at("total").get<int>())
          throw std::runtime_error("job " + std::to_string(id) + ": " + std::to_string(sample.touches) +
                                   " job.touch against a total of " + p.at("total").dump());
      }
    }
  }

  // The run's folder, gone with the session, also when its start throws (the first member: the
  // last destroyed). tmpfs: every touch fsyncs the job's journal, which on a disk costs more than
  // the touch.
  struct Folder {
    std::filesystem::path path = (std::filesystem::is_directory("/dev/shm") ? std::filesystem::path("/dev/shm")
                                                                             : std::filesystem::temp_directory_path()) /
                                 ("fleet_bench_" + std::to_string(getpid()));
    Folder() {
      std::filesystem::remove_all(path);
      std::filesystem::create_directories(path);
    }
    ~Folder() {
      std::error_code ignored;
      std::filesystem::remove_all(path, ignored);
    }
  } folder_holder_;
  const std::filesystem::path& folder_ = folder_holder_.path;
  std::filesystem::path model_;
  json registration_;
  std::unique_ptr<testing::BrokerProcess> broker_;
  int broker_pid_ = 0;
  std::unique_ptr<FleetTraffic> fleet_;
  Station stations_[kVariantCount];
  std::vector<JobSample> samples_[kVariantCount];
  double fleet_msgs_per_s_ = 0;
};

std::unique_ptr<Session> g_session;
std::string g_session_error;

// Every benchmark reports the jobs the one session ran: run inside a benchmark, one variant's jobs
// would all come before the next's, and a drift of the machine would read as the link's cost.
const Session* session() {
  if (!g_session && g_session_error.empty()) try {
      g_session = std::make_unique<Session>(g_rounds);
    } catch (const std::exception& e) {
      g_session_error = e.what();
    }
  return g_session.get();
}

template <typename Field>
double mean(const std::vector<JobSample>& samples, Field field) {
  double sum = 0;
  for (const JobSample& s : samples) sum += field(s);
  return sum / static_cast<double>(samples.size());
}

double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 == 1 ? values[n / 2] : (values[n / 2 - 1] + values[n / 2]) / 2;
}

// One iteration per job of the variant, its manual time the job's time per touch.
void bm_fleet_touch(benchmark::State& state) {
  const int variant = static_cast<int>(state.range(0));
  const Session* s = session();
  if (!s) return state.SkipWithError(g_session_error.c_str());
  const std::vector<JobSample>& samples = s->samples(variant);
  std::size_t i = 0;
  for (auto _ : state) state.SetIterationTime(samples[i++ % samples.size()].per_touch_s());
  const auto per_touch_us = [&](auto seconds_of) {
    return mean(samples, [&](const JobSample& j) { return seconds_of(j) / j.touches * 1e6; });
  };
  state.SetLabel(kVariants[variant].name);
  state.counters["touches"] = mean(samples, [](const JobSample& j) { return j.touches; });
  state.counters["us_per_touch"] = per_touch_us([](const JobSample& j) { return j.probing_s; });
  state.counters["journal_us"] = per_touch_us([](const JobSample& j) { return j.journal_s; });
  state.counters["job_run_us"] = per_touch_us([](const JobSample& j) { return j.job_run_s; });
  state.counters["job_wait_us"] = per_touch_us([](const JobSample& j) { return j.job_wait_s; });
  state.counters["cmmd_cpu_us"] = per_touch_us([](const JobSample& j) { return j.cmmd_run_s; });
  state.counters["broker_cpu_us"] = per_touch_us([](const JobSample& j) { return j.broker_run_s; });
  state.counters["broker_msg_s"] = mean(samples, [](const JobSample& j) { return j.broker_msgs_per_s; });
  state.counters["fleet_msg_s"] = s->fleet_msgs_per_s();
  std::vector<double> us;
  for (const JobSample& j : samples) us.push_back(j.per_touch_s() * 1e6);
  state.counters["median_us"] = median(us);
  if (variant != 0) {
    // Against off, by rounds (a round's jobs ran back to back): the median of the rounds' ratios,
    // which one job slowed by the VM (it happens: a job thread's own run time up 50 %) does not
    // move, the ratio of the means, and the worst round.
    const std::vector<JobSample>& off = s->samples(0);
    std::vector<double> ratios;
    for (std::size_t r = 0; r < samples.size(); ++r) ratios.push_back(samples[r].per_touch_s() / off[r].per_touch_s());
    state.counters["vs_off"] = median(ratios);
    state.counters["vs_off_means"] = mean(samples, [](const JobSample& j) { return j.per_touch_s(); }) /
                                     mean(off, [](const JobSample& j) { return j.per_touch_s(); });
    state.counters["worst_round_vs_off"] = *std::max_element(ratios.begin(), ratios.end());
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<char*> args;
  for (int i = 0; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg.starts_with("--rounds=")) g_rounds = std::max(1, std::atoi(arg.c_str() + 9));
    else if (arg.starts_with("--spacing=")) g_spacing_mm = std::atof(arg.c_str() + 10);
    else if (arg == "--pin") g_pin = true;
    else args.push_back(argv[i]);
  }
  int n = static_cast<int>(args.size());
  if (g_pin) {  // before any thread or child: they inherit it
    cpu_set_t core1;
    CPU_ZERO(&core1);
    CPU_SET(1, &core1);
    if (sched_setaffinity(0, sizeof core1, &core1) != 0) {
      std::perror("sched_setaffinity");
      return 1;
    }
  }
  benchmark::RegisterBenchmark("bm_fleet_touch", bm_fleet_touch)
      ->ArgName("variant")
      ->DenseRange(0, kVariantCount - 1)
      ->UseManualTime()
      ->Iterations(g_rounds)
      ->Unit(benchmark::kMicrosecond);
  benchmark::Initialize(&n, args.data());
  if (benchmark::ReportUnrecognizedArguments(n, args.data())) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  g_session.reset();  // the cmmd, the fleet and the broker stop here, not in static destruction
  return 0;
}
