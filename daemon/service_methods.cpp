// The machine.*, model.*, plan.* and job.* methods cmmd serves, each with the role it needs.
#include "daemon/service_methods.hpp"

#include <cstdint>
#include <functional>
#include <limits>

#include <spdlog/spdlog.h>

#include "hal/description/eigen_json.hpp"
#include "daemon/job_view.hpp"
#include "daemon/machine_jog.hpp"
#include "daemon/plan_preview.hpp"
#include "daemon/touch_motion.hpp"
#include "geometry/file_error.hpp"
#include "hal/fault.hpp"
#include "hal/qualification.hpp"
#include "planner/registration.hpp"

namespace cmm::daemon {

namespace {

int job_id(const nlohmann::json& params) {
  if (!params.is_object() || !params.contains("job") || !params["job"].is_number_integer())
    throw_invalid_param("/job", "must be a job id (integer)");
  // Compared before narrowing: job 4294967297 is no job, not job 1.
  const nlohmann::json& id = params["job"];
  const bool fits = id.is_number_unsigned() ? id.get<std::uint64_t>() <= std::numeric_limits<int>::max()
                                            : id.get<std::int64_t>() >= 0 && id.get<std::int64_t>() <= std::numeric_limits<int>::max();
  if (!fits) throw RpcError(rpc_code::not_found, "no job " + id.dump(), {{"job", id}});
  return id.get<int>();
}

std::string text(const nlohmann::json& params, const char* key, const std::string& fallback) {
  if (!params.is_object() || !params.contains(key)) return fallback;
  if (!params[key].is_string()) throw_invalid_param(std::string("/") + key, "must be a string");
  return params[key].get<std::string>();
}

// Runs a manual machine command with the machine to itself, faults as −32013 with their kind.
// `f(cmm, check_stop)` calls check_stop before each of its motions, and it is called once more
// after f: a machine.stop since the command was asked for ends it (Aborted) as one during a motion
// does, even one that came just as a motion was being sent and so did not stop it.
template <class F>
nlohmann::json with_machine(Service& s, const std::string& what, F&& f) {
  const std::function<void()> check_stop = s.machine.stop_check();  // a stop while it waits counts too
  std::optional<MachineLink::Lease> lease = s.machine.lease_after_reconnect(what, std::chrono::seconds(10));
  if (!lease) {
    const std::string holder = s.machine.holder().value_or("another command");
    throw RpcError(rpc_code::machine_busy, "the machine is busy: " + holder + " holds it", {{"holder", holder}});
  }
  try {
    s.machine.bring_up();
    // A job stopped mid-touch left the ball on its search line: out the way it came first.
    if (const auto line = s.machine.touch_in_progress(); line && s.machine.cmm().status().homed) {
      const description::MachineDescription& d = s.config.description;
      leave_touch(s.machine.cmm(), line->start, line->direction, d.clearance_z, {0, d.probe_speed_mm_s}, check_stop);
      s.machine.left_touch();
    }
    nlohmann::json result = f(s.machine.cmm(), check_stop);
    check_stop();
    return result;
  } catch (const hal::Fault& fault) {
    throw RpcError(rpc_code::machine_fault, what + ": " + fault.what(), {{"kind", hal::to_string(fault.kind())}});
  } catch (const hal::StateError& e) {
    throw RpcError(rpc_code::invalid_state, what + ": " + e.what());
  }
}

void add_machine_methods(RpcDispatcher& d, Service& s, const std::shared_ptr<MachineJog>& jog) {
  d.add("machine.status", {Role::observer, Work::blocking, [&s, jog](const nlohmann::json&, RpcContext&) {
          nlohmann::json j = s.machine.status_json();
          j["tips"] = s.machine.tips_json();
          if (const auto running = s.jobs.running_job()) j["job"] = *running;
          j["jog"] = jog->status_json();
          j["last_jog"] = jog->last_json();
          return j;
        }});
  d.add("machine.home", {Role::operator_, Work::blocking, [&s](const nlohmann::json&, RpcContext&) {
          return with_machine(s, "machine.home", [&s](hal::Cmm& cmm, const std::function<void()>& check_stop) {
            check_stop();
            cmm.home();
            s.machine.left_touch();  // the operator homed it: wherever the ball was, it is home now
            return nlohmann::json{{"position", description::vec3_json(cmm.status().position)}};
          });
        }});
  // stop and abort run on the io thread: they must never wait behind a slow method. A stop is always
  // safe, so every authenticated client may stop, observers too; an abort latches until an operator's reset.
  d.add("machine.stop", {Role::observer, Work::quick, [&s](const nlohmann::json&, RpcContext& ctx) {
          spdlog::warn("machine.stop from {}", ctx.peer());
          s.machine.count_stop();
          s.jobs.machine_stopped();
          try {
            s.machine.cmm().stop();
          } catch (const hal::Fault& f) {
            throw RpcError(rpc_code::machine_fault, std::string("stop: ") + f.what(), {{"kind", hal::to_string(f.kind())}});
          } catch (const hal::StateError&) {
            // Not connected: nothing moves that could be stopped.
          }
          return nlohmann::json::object();
        }});
  d.add("machine.abort", {Role::operator_, Work::quick, [&s](const nlohmann::json&, RpcContext& ctx) {
          spdlog::warn("machine.abort from {}", ctx.peer());
          s.machine.count_stop();
          s.jobs.machine_stopped();
          try {
            s.machine.cmm().abort();
          } catch (const hal::Fault& f) {
            throw RpcError(rpc_code::machine_fault, std::string("abort: ") + f.what(), {{"kind", hal::to_string(f.kind())}});
          } catch (const hal::StateError&) {
          }
          return nlohmann::json::object();
        }});
  d.add("machine.reset", {Role::operator_, Work::blocking, [&s](const nlohmann::json&, RpcContext&) {
          return with_machine(s, "machine.reset", [](hal::Cmm& cmm, const std::function<void()>&) {
            cmm.reset();
            return nlohmann::json::object();
          });
        }});
  d.add("machine.qualify", {Role::operator_, Work::blocking, [&s](const nlohmann::json& params, RpcContext&) {
          const std::string tip = text(params, "tip", "");
          return with_machine(s, "machine.qualify", [&](hal::Cmm& cmm, const std::function<void()>& check_stop) {
            const description::MachineDescription info = cmm.info();
            const std::string id = tip.empty() ? info.active_tip : tip;
            std::string known;
            bool found = false;
            for (const description::StylusTip& t : info.tips) {
              known += (known.empty() ? "" : ", ") + t.id;
              found = found || t.id == id;
            }
            if (!found) throw_invalid_param("/tip", "the machine has no tip \"" + id + "\" (its tips: " + known + ")");
            if (!cmm.status().homed) {
              check_stop();
              cmm.home();
            }
            hal::QualificationOptions options;
            options.before_motion = check_stop;
            const description::TipQualification q = s.machine.qualify(id, options);
            spdlog::info("tip {} qualified: r {:.5f} mm, rms {:.5f} mm", id, q.ball_radius_mm, q.residual_rms_mm);
            return nlohmann::json{{"tip", id},
                                  {"ball_radius_mm", q.ball_radius_mm},
                                  {"offset", description::vec3_json(q.offset)},
                                  {"residual_rms_mm", q.residual_rms_mm},
                                  {"touches", q.touches},
                                  {"time_utc", q.time_utc}};
          });
        }});
}

void add_model_and_plan_methods(RpcDispatcher& d, Service& s) {
  d.add("model.upload", {Role::operator_, Work::blocking, [&s](const nlohmann::json& p, RpcContext&) {
          if (!p.is_object()) throw_invalid_param("", "must be an object");
          UploadChunk chunk;
          chunk.name = text(p, "name", "");
          chunk.sha256_hex = text(p, "sha256", "");
          chunk.data_base64 = text(p, "data", "");
          for (const char* key : {"size", "offset"})
            if (!p.contains(key) || !p[key].is_number_unsigned()) throw_invalid_param(std::string("/") + key, "must be a byte count");
          chunk.size = p["size"].get<std::uint64_t>();
          chunk.offset = p["offset"].get<std::uint64_t>();
          const UploadStatus st = s.models.upload(chunk);
          return nlohmann::json{{"model", st.model}, {"received", st.received}, {"complete", st.complete}};
        }});
  d.add("plan.preview", {Role::observer, Work::planning, [&s](const nlohmann::json& p, RpcContext& ctx) {
          std::optional<description::MachineDescription> info;
          try {  // only read: an observer's preview never connects or enables the machine
            info = s.machine.cmm().info();
          } catch (const std::exception& e) {
            spdlog::info("plan.preview without the machine's tips: {}", e.what());
          }
          // Its client gone (or cmmd stopping, which closes every connection): nobody reads the answer.
          const geometry::CancelCheck cancel{[&ctx] { return ctx.closed(); }};
          try {
            return preview_plan(p, s.config, s.models, info ? &*info : nullptr, cancel);
          } catch (const geometry::Cancelled& e) {
            throw RpcError(rpc_code::shutting_down, std::string("plan.preview abandoned: its connection closed (") +
                                                        e.what() + ")");
          }
        }});
  d.add("registration.fit", {Role::observer, Work::blocking, [&s](const nlohmann::json& p, RpcContext&) {
          try {
            nlohmann::json input = p;
            if (!input.contains("plate")) input["plate"] = description::to_json(s.config.plate);
            const planner::RegistrationResult r =
                planner::fit_registration(planner::registration_from_json(input, "registration.fit"));
            return planner::to_json(r);
          } catch (const planner::RegistrationError& e) {
            throw RpcError(rpc_code::registration_error, e.what(), {{"corners", e.corners()}});
          } catch (const RpcError&) {
            throw;
          } catch (const description::FieldError& e) {  // every bad field of the params, by its JSON Pointer
            throw invalid_params(e);
          } catch (const std::exception& e) {
            throw_invalid_param("", e.what());
          }
        }});
}

void add_job_methods(RpcDispatcher& d, Service& s) {
  d.add("job.submit", {Role::operator_, Work::blocking, [&s](const nlohmann::json& p, RpcContext&) { return s.jobs.submit(p); }});
  d.add("job.get", {Role::observer, Work::quick, [&s](const nlohmann::json& p, RpcContext&) { return s.jobs.get(job_id(p)); }});
  d.add("job.list", {Role::observer, Work::quick, [&s](const nlohmann::json&, RpcContext&) { return s.jobs.list(); }});
  d.add("job.pause", {Role::operator_, Work::quick, [&s](const nlohmann::json& p, RpcContext&) { return s.jobs.pause(job_id(p)); }});
  d.add("job.resume", {Role::operator_, Work::quick, [&s](const nlohmann::json& p, RpcContext&) {
          bool reregister = false;
          if (p.contains("reregister")) {
            if (!p["reregister"].is_boolean()) throw_invalid_param("/reregister", "must be true or false");
            reregister = p["reregister"].get<bool>();
          }
          return s.jobs.resume(job_id(p), reregister);
        }});
  d.add("job.cancel", {Role::operator_, Work::quick, [&s](const nlohmann::json& p, RpcContext&) { return s.jobs.cancel(job_id(p)); }});
  d.add("job.result", {Role::observer, Work::blocking, [&s](const nlohmann::json& p, RpcContext&) {
          return s.jobs.result(job_id(p), text(p, "format", "json"));
        }});
  // The job's self-contained HTML report (report.html), for cmmctl report and the dashboard.
  d.add("job.report", {Role::observer, Work::blocking, [&s](const nlohmann::json& p, RpcContext&) {
          return s.jobs.result(job_id(p), "html");
        }});
  // What the dashboard draws of a job (daemon/job_view.hpp); off the io thread: it reads the job's files.
  d.add("job.view", {Role::observer, Work::blocking, [&s](const nlohmann::json& p, RpcContext&) {
          const int id = job_id(p);
          s.jobs.get(id);  // −32010 for no such job
          return job_view(s.jobs.store(), id);
        }});
}

}  // namespace

void add_service_methods(RpcDispatcher& dispatcher, Service& service) {
  dispatcher.add("server.info", {Role::none, Work::quick, [&service, &dispatcher](const nlohmann::json&, RpcContext& ctx) {
                   return nlohmann::json{{"name", "cmmd"},
                                         {"version", service.version},
                                         {"api", "cmmd.api/1"},
                                         {"role", to_string(ctx.role())},
                                         {"driver", service.machine.driver()},
                                         {"methods", dispatcher.methods()}};
                 }});
  // machine.jog and machine.jog_stop (daemon/machine_jog.hpp); the jog ends with the dispatcher.
  const auto jog = std::make_shared<MachineJog>(service.machine, service.config.jog, service.config.description.travel_box);
  add_jog_methods(dispatcher, jog);
  add_machine_methods(dispatcher, service, jog);
  add_model_and_plan_methods(dispatcher, service);
  add_job_methods(dispatcher, service);
}

}  // namespace cmm::daemon
