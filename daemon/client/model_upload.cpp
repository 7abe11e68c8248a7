// Uploading a model file to cmmd in sha256-named base64 chunks, resuming where cmmd says it stands.
#include "daemon/client/model_upload.hpp"

#include <fstream>
#include <vector>

#include "daemon/client/base64.hpp"
#include "daemon/client/sha256.hpp"
#include "geometry/file_error.hpp"

namespace cmm::daemon {

std::string upload_model(RpcClient& client, const std::filesystem::path& file, std::size_t chunk_bytes,
                         const std::function<void(std::uint64_t, std::uint64_t)>& progress) {
  const std::string sha = sha256_hex_of_file(file);
  std::error_code ec;
  const std::uint64_t size = std::filesystem::file_size(file, ec);
  if (ec) throw geometry::FileError::whole(file, ec.message());
  std::ifstream in(file, std::ios::binary);
  if (!in) throw geometry::FileError::whole(file, "cannot be opened");
  std::vector<char> buffer(chunk_bytes);
  std::uint64_t offset = 0;
  for (;;) {
    in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    const auto got = static_cast<std::size_t>(in.gcount());
    if (got == 0 && offset < size) throw geometry::FileError::at_byte(file, offset, "ended early (changed while uploading?)");
    const nlohmann::json reply = client.call("model.upload", {{"name", file.filename().string()},
                                                              {"size", size},
                                                              {"sha256", sha},
                                                              {"offset", offset},
                                                              {"data", encode_base64({buffer.data(), got})}});
    offset = reply.at("received").get<std::uint64_t>();
    if (progress) progress(offset, size);
    if (reply.at("complete").get<bool>()) return reply.at("model").get<std::string>();
    if (got == 0) throw geometry::FileError::at_byte(file, offset, "cmmd did not complete the upload at the end of the file");
    in.clear();
    in.seekg(static_cast<std::streamoff>(offset));
  }
}

}  // namespace cmm::daemon
