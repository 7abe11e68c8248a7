// URL paths to files under a root, their content types, and where the dashboard's files live.
#include "daemon/static_files.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <utility>

#ifndef CMMD_WEB_ROOT
#define CMMD_WEB_ROOT ""
#endif
#ifndef CMMD_INSTALLED_WEB_ROOT
#define CMMD_INSTALLED_WEB_ROOT "/usr/local/share/cmmd/web"
#endif

namespace cmm::daemon {

namespace fs = std::filesystem;

namespace {

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// Whether `inside` is `root` or below it, component by component (so /web2 is not below /web).
bool is_within(const fs::path& root, const fs::path& inside) {
  auto r = root.begin(), i = inside.begin();
  for (; r != root.end(); ++r, ++i)
    if (i == inside.end() || *r != *i) return false;
  return true;
}

}  // namespace

std::optional<std::string> percent_decode(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] != '%') {
      out += text[i];
      continue;
    }
    if (i + 2 >= text.size()) return std::nullopt;
    const int high = hex_value(text[i + 1]), low = hex_value(text[i + 2]);
    if (high < 0 || low < 0) return std::nullopt;
    const char c = static_cast<char>(high * 16 + low);
    if (c == '\0') return std::nullopt;
    out += c;
    i += 2;
  }
  return out;
}

ResolvedFile resolve_under(const fs::path& root, std::string_view relative) {
  if (relative.find('\0') != std::string_view::npos) return {FileLookup::bad_path, {}};
  // ".." is refused before the file system is asked, whatever it would lead to.
  std::size_t begin = 0;
  while (begin <= relative.size()) {
    const std::size_t end = std::min(relative.find('/', begin), relative.size());
    if (relative.substr(begin, end - begin) == "..") return {FileLookup::bad_path, {}};
    begin = end + 1;
  }
  while (!relative.empty() && relative.front() == '/') relative.remove_prefix(1);
  if (relative.empty()) return {FileLookup::not_found, {}};
  std::error_code ec;
  const fs::path canonical_root = fs::canonical(root, ec);
  if (ec) return {FileLookup::not_found, {}};
  // canonical() follows every symlink: a link to a file outside the root ends outside it.
  const fs::path file = fs::canonical(canonical_root / fs::path(relative), ec);
  if (ec || !is_within(canonical_root, file) || !fs::is_regular_file(file, ec)) return {FileLookup::not_found, {}};
  return {FileLookup::found, file};
}

std::string content_type(const fs::path& file) {
  static constexpr std::array<std::pair<std::string_view, std::string_view>, 22> types{{
      {".html", "text/html; charset=utf-8"},
      {".htm", "text/html; charset=utf-8"},
      // A JavaScript MIME type is what a browser needs to run a file as an ES module.
      {".js", "text/javascript; charset=utf-8"},
      {".mjs", "text/javascript; charset=utf-8"},
      {".css", "text/css; charset=utf-8"},
      {".json", "application/json"},
      {".map", "application/json"},
      {".txt", "text/plain; charset=utf-8"},
      {".svg", "image/svg+xml"},
      {".png", "image/png"},
      {".jpg", "image/jpeg"},
      {".jpeg", "image/jpeg"},
      {".gif", "image/gif"},
      {".webp", "image/webp"},
      {".ico", "image/vnd.microsoft.icon"},
      {".woff", "font/woff"},
      {".woff2", "font/woff2"},
      {".ttf", "font/ttf"},
      {".wasm", "application/wasm"},
      {".pdf", "application/pdf"},
      {".csv", "text/csv; charset=utf-8"},
      {".xml", "application/xml"},
  }};
  std::string extension = file.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  for (const auto& [known, type] : types)
    if (extension == known) return std::string(type);
  return "application/octet-stream";
}

fs::path default_web_root() {
  std::error_code ec;
  const fs::path build_tree = CMMD_WEB_ROOT;
  if (!build_tree.empty() && fs::is_directory(build_tree, ec)) return build_tree;
  return CMMD_INSTALLED_WEB_ROOT;
}

}  // namespace cmm::daemon
