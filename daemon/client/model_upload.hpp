// The client side of model.upload: a mesh file sent to cmmd in base64 chunks with its sha256, so
// the sandboxed service never reads the operator's home folder (cmmctl submit, the tests).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

#include "daemon/client/rpc_client.hpp"

namespace cmm::daemon {

// Returns the model's name for job.submit ("sha256:<hex>"). A model cmmd already has costs one
// call. `progress(sent, size)` after each chunk. Throws RpcError / RpcClientError, and
// geometry::FileError naming the file when it cannot be read.
std::string upload_model(RpcClient& client, const std::filesystem::path& file, std::size_t chunk_bytes = 1u << 20,
                         const std::function<void(std::uint64_t, std::uint64_t)>& progress = {});

}  // namespace cmm::daemon
