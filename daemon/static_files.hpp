// Files the dashboard's server hands out: a URL path to a file under a root that no "..", encoded
// or not, and no symlink can leave; the Content-Type of a file; where the dashboard's files are.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

namespace cmm::daemon {

// "%2e%2E" → "..": nullopt for a malformed escape or an encoded NUL. '+' stays '+' (a path, not a form).
std::optional<std::string> percent_decode(std::string_view text);

enum class FileLookup {
  found,      // a regular file inside the root
  not_found,  // nothing there, a folder, or a symlink that leads out of the root: 404
  bad_path,   // a ".." segment, a NUL: the request is refused as malformed (400)
};

struct ResolvedFile {
  FileLookup lookup = FileLookup::not_found;
  std::filesystem::path path;  // canonical, when found
};

// `relative` is an already decoded path below `root` ("build/three.module.js").
ResolvedFile resolve_under(const std::filesystem::path& root, std::string_view relative);

// By the file's extension, with charset for text; application/octet-stream when unknown.
std::string content_type(const std::filesystem::path& file);

// The dashboard's files when cmmd.json sets no http.web_root: the source tree's daemon/web for a
// binary run from its build tree, else the installed share/cmmd/web (both fixed at build time).
std::filesystem::path default_web_root();

}  // namespace cmm::daemon
