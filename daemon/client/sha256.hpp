// SHA-256 digests as model.upload checks them and names stored models by them ("sha256:<hex>");
// cmmctl computes the same digest before it uploads.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

namespace cmm::daemon {

// An incremental digest: feed bytes in any pieces, then read the lowercase hex of the whole.
class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;

  void update(std::string_view bytes);
  std::string hex_digest();  // finishes the digest; call once

 private:
  struct Context;
  std::unique_ptr<Context> context_;
};

// The digest of a file's bytes, read in pieces; geometry::FileError naming the file if unreadable.
std::string sha256_hex_of_file(const std::filesystem::path& file);

// Whether `text` is a digest as sha256_hex_of_file prints it: 64 lowercase hex digits.
bool is_sha256_hex(std::string_view text);

}  // namespace cmm::daemon
