// How a long computation hears that its result is no longer wanted (a job cancelled, its client
// gone, cmmd stopping): it polls between steps and stops by throwing Cancelled.
#pragma once

#include <functional>
#include <stdexcept>
#include <string>

namespace cmm::geometry {

struct Cancelled : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct CancelCheck {
  std::function<bool()> requested;  // empty: never; must be cheap and safe from any thread

  bool stop_requested() const { return requested && requested(); }
  // `where`: the step that stopped, for the log ("feature curves").
  void throw_if_requested(const char* where) const {
    if (stop_requested()) throw Cancelled(std::string("stopped during ") + where);
  }
};

}  // namespace cmm::geometry
