// Which failed writes are a full disk, and how a job and a client are told.
#include "daemon/storage_error.hpp"

#include <cerrno>

#include "geometry/file_error.hpp"

namespace cmm::daemon {

bool StorageFailure::full() const { return error_number == ENOSPC || error_number == EDQUOT; }

std::string StorageFailure::hold_reason() const {
  return full() ? "storage full: " + message + "; free space, then job.resume"
                : "storage error: " + message + "; fix it, then job.resume";
}

const char* StorageFailure::fault_kind() const { return full() ? "StorageFull" : "Storage"; }

std::optional<StorageFailure> storage_failure(const std::exception& e) {
  if (const auto* file = dynamic_cast<const geometry::FileError*>(&e); file && file->error_number() != 0)
    return StorageFailure{file->file(), file->error_number(), file->what()};
  if (const auto* fs = dynamic_cast<const std::filesystem::filesystem_error*>(&e); fs && fs->code())
    return StorageFailure{fs->path1(), fs->code().value(), fs->what()};
  return std::nullopt;
}

RpcError storage_full_error(const StorageFailure& failure, nlohmann::json data) {
  data["file"] = failure.file.string();
  return RpcError(rpc_code::storage_full, failure.message + " (free space in cmmd's state folder, then try again)",
                  std::move(data));
}

}  // namespace cmm::daemon
