// Writing a job's files so that a crash at any moment leaves either the old file or the new one,
// never half of one: temp file, fsync, rename, fsync of the folder (DESIGN.md, Files).
#pragma once

#include <filesystem>
#include <string_view>

namespace cmm::daemon {

// Replaces `file` with `content`. Throws geometry::FileError naming the file and the step that
// failed; the old file, if any, is then untouched and no temp file is left behind.
void write_atomically(const std::filesystem::path& file, std::string_view content);

// fsync of a folder, so that a rename or a new file in it survives a power cut.
void sync_folder(const std::filesystem::path& folder);

}  // namespace cmm::daemon
