// Test support: a hal::Cmm in front of another that records every motion command it passes on
// (home, move, probe) with the machine clock around it, and lets a test act just before a command
// goes out (set a job's cancel flag, stop the machine).
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "hal/cmm.hpp"

namespace cmm::daemon::testing {

struct RecordedCommand {
  enum class Kind { home, move, probe } kind = Kind::move;
  hal::Move move;
  hal::ProbeMove probe;
  double t_before_s = 0, t_after_s = 0;  // the machine clock around it
};

class RecordingCmm : public hal::Cmm {
 public:
  explicit RecordingCmm(std::unique_ptr<hal::Cmm> inner) : inner_(std::move(inner)) {}

  std::vector<RecordedCommand> commands;
  // Runs before a motion command is passed on, with its index in `commands` (it is recorded first).
  std::function<void(std::size_t index, const RecordedCommand&)> before;
  hal::Cmm& inner() { return *inner_; }

  void configure(const nlohmann::json& block) override { inner_->configure(block); }
  void connect() override { inner_->connect(); }
  void enable() override { inner_->enable(); }
  void disable() override { inner_->disable(); }
  void disconnect() override { inner_->disconnect(); }
  std::optional<description::MachineDescription> configured_machine() const override {
    return inner_->configured_machine();
  }
  description::MachineDescription info() override { return inner_->info(); }
  hal::MachineStatus status() override { return inner_->status(); }
  void home() override {
    record({RecordedCommand::Kind::home, {}, {}});
    inner_->home();
    done();
  }
  void move(const hal::Move& m) override {
    record({RecordedCommand::Kind::move, m, {}});
    inner_->move(m);
    done();
  }
  hal::TouchResult probe(const hal::ProbeMove& p) override {
    record({RecordedCommand::Kind::probe, {}, p});
    const hal::TouchResult r = inner_->probe(p);
    done();
    return r;
  }
  void stop() override { inner_->stop(); }
  void abort() override { inner_->abort(); }
  void reset() override { inner_->reset(); }
  void select_tip(const std::string& tip_id) override { inner_->select_tip(tip_id); }
  void record_qualification(const std::string& tip_id, const description::TipQualification& q) override {
    inner_->record_qualification(tip_id, q);
  }

 private:
  void record(RecordedCommand c) {
    c.t_before_s = inner_->status().t_s;
    commands.push_back(c);
    if (before) before(commands.size() - 1, commands.back());
  }
  void done() { commands.back().t_after_s = inner_->status().t_s; }

  std::unique_ptr<hal::Cmm> inner_;
};

}  // namespace cmm::daemon::testing
