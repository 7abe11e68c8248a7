// The one durable writer (DESIGN.md, Files): a file is replaced so that a crash at any moment leaves
// either the old file or the new one, never half of one — temp file, fsync, rename, fsync of the
// folder; and the two variants cmmd's state needs, a record written into space kept aside for it and
// a chunk written at an offset; and the sweep of the temps a writer killed mid-write left. Every
// failure is a FileError with the errno of the call that failed, so a full disk (ENOSPC, EDQUOT) can
// be told from a broken one.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace cmm::geometry {

// Replaces `file` with `content` through a temp file beside it, ".<name>.tmp-<writer's pid>" (the
// one pattern atomic_temp_writer knows). On failure the old file, if any, is untouched and no temp
// file is left behind. Given a `mode`, the new file has exactly that one from its creation (a secret is never
// readable by others, not even for a moment); otherwise 0644 less the umask.
void write_atomically(const std::filesystem::path& file, std::string_view content,
                      std::optional<unsigned> mode = std::nullopt);

// The same through `spare`, a file in the same folder whose blocks are already allocated
// (allocate_spare): `content` is written into them and the spare renamed over `file`, so no new
// space is needed — a state record still saves on a full disk. False (nothing changed but the spare,
// which is then gone) when the spare is missing, too small or cannot be written: the caller writes
// atomically instead.
bool write_through_spare(const std::filesystem::path& file, const std::filesystem::path& spare,
                         std::string_view content, std::size_t spare_bytes);
// Allocates `bytes` for `spare` if it is missing; false when there is no room (no half spare is kept).
bool allocate_spare(const std::filesystem::path& spare, std::size_t bytes);

// Writes `bytes` at `offset` of `file` (created if missing), cutting whatever lay beyond, and makes
// it durable. On failure the file is cut back to `offset`: it holds exactly what it held before
// this chunk, so nothing half written is ever counted as received.
void write_chunk(const std::filesystem::path& file, std::uint64_t offset, std::string_view bytes);

// fsync of a folder, so that a rename or a new file in it survives a power cut.
void sync_folder(const std::filesystem::path& folder);

// The pid of the process that wrote `path` when its name is one of write_atomically's temp files,
// else nothing: the sweep below and the writer share this one definition of the name.
std::optional<int> atomic_temp_writer(const std::filesystem::path& path);
inline bool is_atomic_temp(const std::filesystem::path& path) { return atomic_temp_writer(path).has_value(); }

struct TempSweep {
  std::size_t removed = 0;
  std::vector<std::string> problems;  // what could not be listed or removed, with the path and why
};

// Removes, at any depth under `root`, the temp files of writers killed mid-write (a killed writer
// never unlinks its temp, and a later one, under another pid, writes through another): those whose
// pid is no running process, or is this process's own (a container starts cmmd under the same pid every
// time). So call it before this process writes under `root`. A temp of another live process stays.
// Never throws: a start is not stopped by a stray file, the problems say what is left.
TempSweep remove_stale_atomic_temps(const std::filesystem::path& root);

}  // namespace cmm::geometry
