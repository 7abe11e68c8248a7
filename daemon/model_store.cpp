// model.upload's chunk bookkeeping (the partial file's size is the upload's state) and the
// resolution of model references, with the path checks that keep "file:" inside models_dir.
#include "daemon/model_store.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <vector>

#include "geometry/atomic_file.hpp"
#include "daemon/client/base64.hpp"
#include "daemon/client/rpc_error.hpp"
#include "daemon/client/sha256.hpp"
#include "daemon/storage_error.hpp"
#include "geometry/file_error.hpp"
#include "geometry/mesh_io.hpp"

namespace cmm::daemon {

namespace fs = std::filesystem;

namespace {

// What geometry::read_model reads: meshes and raw scans (point clouds) alike.
const std::vector<std::string>& model_extensions() {
  static const std::vector<std::string> extensions = geometry::model_extensions();
  return extensions;
}

bool known_extension(const std::string& ext) {
  return std::find(model_extensions().begin(), model_extensions().end(), ext) != model_extensions().end();
}

// ".stl, .ply, ... or .pcd", for the messages.
std::string extension_list() {
  const auto& all = model_extensions();
  std::string list;
  for (std::size_t i = 0; i < all.size(); ++i) list += (i == 0 ? "" : i + 1 == all.size() ? " or " : ", ") + all[i];
  return list;
}

RpcError upload_failed(const std::string& message, std::uint64_t expected_offset) {
  return RpcError(rpc_code::upload_error, message, {{"expected_offset", expected_offset}});
}

std::string lowercase(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

std::string model_extension(const std::string& name) {
  const std::string ext = lowercase(fs::path(name).extension().string());
  if (!known_extension(ext))
    throw_invalid_param("/name", "\"" + name + "\" is not a model file (expected a mesh or a point cloud: " +
                                     extension_list() + ")");
  return ext;
}

std::uint64_t size_or_zero(const fs::path& file) {
  std::error_code error;
  const auto size = fs::file_size(file, error);
  return error ? 0 : size;
}

}  // namespace

ModelStore::ModelStore(fs::path state_models_dir, fs::path models_dir, std::uint64_t max_model_bytes)
    : dir_(std::move(state_models_dir)),
      partial_dir_(dir_ / ".partial"),
      models_dir_(std::move(models_dir)),
      max_model_bytes_(max_model_bytes) {
  fs::create_directories(partial_dir_);
}

fs::path ModelStore::stored_file(const std::string& sha256_hex, const std::string& extension) const {
  const fs::path file = dir_ / (sha256_hex + extension);
  return fs::is_regular_file(file) ? file : fs::path();
}

std::vector<std::string> ModelStore::stored_extensions(const std::string& sha256_hex) const {
  std::vector<std::string> found;
  for (const std::string& ext : model_extensions())
    if (!stored_file(sha256_hex, ext).empty()) found.push_back(ext);
  return found;
}

UploadStatus ModelStore::upload(const UploadChunk& chunk) {
  const std::string sha = lowercase(chunk.sha256_hex);
  if (!is_sha256_hex(sha)) throw_invalid_param("/sha256", "sha256 must be 64 hex digits, got \"" + chunk.sha256_hex + "\"");
  const std::string ext = model_extension(chunk.name);
  const std::string model = "sha256:" + sha + ext;
  if (chunk.size > max_model_bytes_)
    throw upload_failed("model of " + std::to_string(chunk.size) + " bytes is over the limit of " +
                            std::to_string(max_model_bytes_) + " bytes (" + std::to_string(max_model_bytes_ >> 20) +
                            " MiB)",
                        0);
  std::string bytes;
  try {
    bytes = decode_base64(chunk.data_base64);
  } catch (const std::invalid_argument& e) {
    throw_invalid_param("/data", e.what());
  }

  std::lock_guard lock(mutex_);
  if (!stored_file(sha, ext).empty()) return {model, chunk.size, true};
  // The same bytes stored under another format's extension: the format is the client's word, so
  // the bytes are kept under this one too (a hard link, no bytes sent again).
  if (const std::vector<std::string> others = stored_extensions(sha); !others.empty()) {
    fs::create_hard_link(stored_file(sha, others.front()), dir_ / (sha + ext));
    geometry::sync_folder(dir_);
    return {model, chunk.size, true};
  }
  const fs::path part = partial_dir_ / (sha + ".part");
  const std::uint64_t received = size_or_zero(part);
  if (chunk.offset != 0 && chunk.offset != received)
    throw upload_failed("chunk at offset " + std::to_string(chunk.offset) + " out of order: " + std::to_string(received) +
                            " bytes received so far",
                        received);
  if (chunk.offset + bytes.size() > chunk.size) {
    fs::remove(part);
    throw upload_failed("chunk at offset " + std::to_string(chunk.offset) + " brings " +
                            std::to_string(chunk.offset + bytes.size()) + " bytes, more than the declared size " +
                            std::to_string(chunk.size) + "; upload dropped",
                        0);
  }
  try {
    if (chunk.offset == 0 || !bytes.empty()) geometry::write_chunk(part, chunk.offset, bytes);
    if (chunk.offset == 0) geometry::sync_folder(partial_dir_);  // the part file itself survives a power cut
    const std::uint64_t now_received = chunk.offset + bytes.size();
    if (now_received < chunk.size) return {model, now_received, false};
    return finish(sha, ext, chunk.size);
  } catch (const RpcError&) {
    throw;
  } catch (const std::exception& e) {
    // A full disk: −32021 with the file, and where to go on from once there is room.
    if (const auto failure = storage_failure(e); failure && failure->full())
      throw storage_full_error(*failure, {{"expected_offset", size_or_zero(part)}});
    throw;
  }
}

UploadStatus ModelStore::finish(const std::string& sha, const std::string& ext, std::uint64_t size) {
  const fs::path part = partial_dir_ / (sha + ".part");
  const std::string actual = sha256_hex_of_file(part);
  if (actual != sha) {
    fs::remove(part);
    throw upload_failed("sha256 mismatch: the " + std::to_string(size) + " bytes received hash to " + actual +
                            ", not " + sha + "; upload dropped",
                        0);
  }
  const fs::path file = dir_ / (sha + ext);
  fs::rename(part, file);
  geometry::sync_folder(dir_);
  geometry::sync_folder(partial_dir_);
  return {"sha256:" + sha + ext, size, true};
}

std::optional<std::string> model_ref_problem(const std::string& ref) {
  if (ref.rfind("sha256:", 0) == 0) {
    const std::string name = lowercase(ref.substr(7));
    const std::string sha = name.substr(0, std::min<std::size_t>(64, name.size()));
    const std::string ext = name.substr(sha.size());
    if (!is_sha256_hex(sha)) return "\"" + ref + "\": sha256 must be 64 hex digits";
    if (!ext.empty() && !known_extension(ext))
      return "\"" + ref + "\": after the digest only " + extension_list() + " may follow";
    return std::nullopt;
  }
  if (ref.rfind("file:", 0) == 0) {
    const fs::path relative(ref.substr(5));
    if (relative.empty() || relative.is_absolute()) return ref + ": need a relative name inside models_dir";
    for (const auto& part : relative)
      if (part == "..") return ref + ": \"..\" is not allowed";
    return std::nullopt;
  }
  return "\"" + ref + "\" is not a model reference (\"sha256:<hex>\" or \"file:<name>\")";
}

namespace {

[[noreturn]] void throw_not_found(const std::string& field, const std::string& ref, const std::string& message) {
  throw RpcError(rpc_code::not_found, field + ": " + message, {{"model", ref}, {"path", field}});
}

}  // namespace

fs::path ModelStore::resolve(const std::string& ref, const std::string& field) const {
  if (const std::optional<std::string> problem = model_ref_problem(ref)) throw_invalid_param(field, *problem);
  std::lock_guard lock(mutex_);
  if (ref.rfind("file:", 0) == 0) return resolve_file(ref, field);
  // "sha256:<hex>.<ext>" names the format too; plain "sha256:<hex>" is fine while one is stored.
  const std::string name = lowercase(ref.substr(7));
  const std::string sha = name.substr(0, 64), ext = name.substr(64);
  if (!ext.empty()) {
    const fs::path file = stored_file(sha, ext);
    if (file.empty()) throw_not_found(field, ref, "no uploaded model " + ref);
    return file;
  }
  const std::vector<std::string> stored = stored_extensions(sha);
  if (stored.empty()) throw_not_found(field, ref, "no uploaded model " + ref);
  if (stored.size() > 1) {
    std::string names;
    for (const std::string& e : stored) names += (names.empty() ? "" : ", ") + ("sha256:" + sha + e);
    throw_invalid_param(field, "\"" + ref + "\" was uploaded as " + std::to_string(stored.size()) +
                                   " formats: name one (" + names + ")");
  }
  return stored_file(sha, stored.front());
}

fs::path ModelStore::resolve_file(const std::string& ref, const std::string& field) const {
  if (models_dir_.empty()) throw_invalid_param(field, ref + ": no models_dir is configured");
  const fs::path relative(ref.substr(5));
  std::error_code error;
  const fs::path root = fs::weakly_canonical(models_dir_, error);
  if (error) throw_not_found(field, ref, ref + ": models_dir " + models_dir_.string() + " is unreadable");
  // Symlinks inside models_dir may point anywhere; what counts is where they lead.
  const fs::path target = fs::weakly_canonical(root / relative, error);
  const auto [root_end, target_it] = std::mismatch(root.begin(), root.end(), target.begin(), target.end());
  if (error || root_end != root.end()) throw_invalid_param(field, ref + ": leads out of models_dir");
  if (!fs::is_regular_file(target)) throw_not_found(field, ref, ref + ": no such file in " + root.string());
  return target;
}

}  // namespace cmm::daemon
