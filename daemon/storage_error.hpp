// A write to the state folder that failed, told apart from every other error: a full disk (ENOSPC,
// EDQUOT) holds a job and is −32021 storage_full to a client; nothing measured is thrown away for it.
#pragma once

#include <exception>
#include <filesystem>
#include <optional>
#include <string>

#include "daemon/client/rpc_error.hpp"

namespace cmm::daemon {

struct StorageFailure {
  std::filesystem::path file;
  int error_number = 0;  // errno of the failed call
  std::string message;   // "<file>: <step>: No space left on device"
  bool full() const;     // ENOSPC or EDQUOT: freeing space is the cure
  // What a held job says: "storage full: <message>; free space, then job.resume" (or "storage
  // error: …; fix it, then job.resume" for another errno), and the fault kind StorageFull | Storage.
  std::string hold_reason() const;
  const char* fault_kind() const;
};

// The failed system call behind `e`, if it is one: a geometry::FileError that carries an errno (what
// every writer in cmmd throws) or a std::filesystem::filesystem_error. nullopt for anything else
// (bad JSON, a file that is not there), which is no storage failure.
std::optional<StorageFailure> storage_failure(const std::exception& e);

// −32021 storage_full with data {"file"} (and `data` merged in), for a failure that full() says is
// the disk's being full.
RpcError storage_full_error(const StorageFailure& failure, nlohmann::json data = nlohmann::json::object());

// Runs `f`; a full disk under it becomes storage_full_error, everything else passes unchanged.
template <class F>
auto refusing_on_full_disk(F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const RpcError&) {
    throw;
  } catch (const std::exception& e) {
    if (const auto failure = storage_failure(e); failure && failure->full()) throw storage_full_error(*failure);
    throw;
  }
}

}  // namespace cmm::daemon
