// The models cmmd plans from: uploads arriving in base64 chunks (model.upload), kept by content as
// <state>/models/<sha256><ext>, and the "sha256:…" / "file:…" names jobs use to refer to them.
#pragma once

#include <cstdint>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace cmm::daemon {

// One model.upload call's params (docs/api.md).
struct UploadChunk {
  std::string name;        // the client's file name; only its extension is used (geometry::model_extensions)
  std::uint64_t size = 0;  // bytes of the whole model
  std::string sha256_hex;  // of the whole model
  std::uint64_t offset = 0;
  std::string data_base64;  // the bytes at offset
};

// model.upload's result.
struct UploadStatus {
  std::string model;  // "sha256:<hex><ext>": the content and the format it is read as
  std::uint64_t received = 0;
  bool complete = false;
};

// What is wrong with a model reference by its text alone, for the message at its field: not
// "sha256:<64 hex>" with at most a model extension after it, nor "file:<name>" with a relative name
// and no "..". Nothing when it may name a model (whether it does is resolve's to say). job.submit's
// field check and resolve share it.
std::optional<std::string> model_ref_problem(const std::string& ref);

class ModelStore {
 public:
  // 1 GiB: a raw scan is far larger than its mesh. ScanOptions::max_points (20 million points) is
  // 480 MB as binary PLY or PCD of float64 x y z (960 MB with normals, 240/480 MB as float32), and
  // about 0.6 to 0.9 GB as XYZ text; a 5,000,000-face mesh (the model limits) is 250 MB of binary STL.
  static constexpr std::uint64_t default_max_model_bytes = std::uint64_t{1} << 30;

  // `state_models_dir` is created if missing; `models_dir` is the configured read-only folder of
  // "file:" models (empty: none configured).
  ModelStore(std::filesystem::path state_models_dir, std::filesystem::path models_dir,
             std::uint64_t max_model_bytes = default_max_model_bytes);

  // Takes one chunk. Chunks come in order (offset = bytes received so far; offset 0 starts over);
  // the received bytes live in .partial/<sha>.part, durable before this returns, so an upload goes
  // on after a restart. The last chunk checks the sha256 and moves the file in place. Throws
  // RpcError: upload_error (data.expected_offset) for an out-of-order chunk, a size over the limit,
  // more bytes than `size` or a sha256 mismatch (the partial data is then dropped); invalid_params
  // (data.path) for a bad name, digest or base64; storage_full (data.file, data.expected_offset)
  // when the disk is full: the chunk is not kept (the partial file is cut back to the chunks before
  // it) and the same chunk may be sent again once there is room.
  UploadStatus upload(const UploadChunk& chunk);

  // The file a model reference names: "sha256:<hex><ext>" → the upload in that format,
  // "sha256:<hex>" → the upload if it is stored in one format only; "file:<name>" → a file under
  // models_dir. `field` is the JSON Pointer of the request field that held `ref` ("/model",
  // "/nominal/model"): every refusal names it, so a bad nominal is never reported at the model.
  // Throws RpcError: invalid_params with data.path `field` for what model_ref_problem finds, a
  // digest stored in several formats without naming one, no models_dir for "file:", or a name whose
  // symlinks lead out of models_dir; not_found with data {"model", "path": field} when absent.
  std::filesystem::path resolve(const std::string& ref, const std::string& field = "/model") const;

 private:
  std::filesystem::path stored_file(const std::string& sha256_hex, const std::string& extension) const;  // empty if not stored
  std::vector<std::string> stored_extensions(const std::string& sha256_hex) const;
  std::filesystem::path resolve_file(const std::string& ref, const std::string& field) const;
  UploadStatus finish(const std::string& sha256_hex, const std::string& extension, std::uint64_t size);

  std::filesystem::path dir_, partial_dir_, models_dir_;
  std::uint64_t max_model_bytes_;
  mutable std::mutex mutex_;
};

}  // namespace cmm::daemon
