// geometry's write_cloud has no per-point attributes, so this writes its own small PLY: the header
// as text, the body as one packed record per vertex, through POSIX calls so it can be fsync'ed.
#include "planner/measured_cloud.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <utility>

#include "geometry/file_error.hpp"

namespace cmm::planner {

namespace {

static_assert(std::numeric_limits<double>::is_iec559 && std::numeric_limits<float>::is_iec559);

template <typename T>
void append_little_endian(std::string& out, T value) {
  unsigned char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  if constexpr (std::endian::native == std::endian::big) std::reverse(bytes, bytes + sizeof(T));
  out.append(reinterpret_cast<const char*>(bytes), sizeof(T));
}

void append_vertex(std::string& out, const double* xyz, unsigned char source, double uncertainty_mm) {
  for (int k = 0; k < 3; ++k) append_little_endian(out, xyz[k]);
  out.push_back(static_cast<char>(source));
  append_little_endian(out, static_cast<float>(uncertainty_mm));
}

// Closes on every path out, so a failed write leaks no descriptor.
class FileDescriptor {
 public:
  explicit FileDescriptor(int fd) : fd_(fd) {}
  FileDescriptor(const FileDescriptor&) = delete;
  FileDescriptor& operator=(const FileDescriptor&) = delete;
  ~FileDescriptor() {
    if (fd_ >= 0) ::close(fd_);
  }
  int get() const { return fd_; }
  int release() { return std::exchange(fd_, -1); }

 private:
  int fd_;
};

[[noreturn]] void fail(const std::filesystem::path& path, const std::string& what) {
  throw geometry::FileError::system(path, what, errno);
}

void write_all(int fd, const std::string& bytes, const std::filesystem::path& path) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) fail(path, "cannot write");
    done += static_cast<std::size_t>(n);
  }
}

}  // namespace

void write_merged_ply(const std::filesystem::path& path, const geometry::Points& scan_points,
                      const std::vector<MeasuredPoint>& measured, double scan_uncertainty_mm) {
  for (const MeasuredPoint& point : measured) {
    const char* feature = point.method == MeasurementMethod::bore_wall ? "hole" : "edge point";
    if (point.frame != PointFrame::scan) {
      throw CompensationError(feature, point.id, CompensationError::Reason::bad_input,
                              "measured point still in the machine frame; map it with to_scan_frame first");
    }
    if (!point.position.allFinite()) {
      throw CompensationError(feature, point.id, CompensationError::Reason::bad_input, "measured point is not finite");
    }
  }

  const std::size_t count = static_cast<std::size_t>(scan_points.rows()) + measured.size();
  std::string bytes =
      "ply\n"
      "format binary_little_endian 1.0\n"
      "comment cmmd merged cloud: scan points (source 0) and probe-measured points (source 1), mm, frame S\n"
      "element vertex " +
      std::to_string(count) +
      "\n"
      "property double x\n"
      "property double y\n"
      "property double z\n"
      "property uchar source\n"
      "property float uncertainty_mm\n"
      "end_header\n";
  constexpr std::size_t record = 3 * sizeof(double) + 1 + sizeof(float);
  bytes.reserve(bytes.size() + count * record);
  for (Eigen::Index i = 0; i < scan_points.rows(); ++i) {
    append_vertex(bytes, scan_points.row(i).data(), merged_source_scan, scan_uncertainty_mm);
  }
  for (const MeasuredPoint& point : measured) {
    append_vertex(bytes, point.position.data(), merged_source_measured, point.sigma_mm);
  }

  // Temp file, fsync, rename, fsync of the folder (DESIGN.md "Files"): after a crash either the old
  // file or the whole new one is there.
  std::filesystem::path partial = path;
  partial += ".partial";
  {
    FileDescriptor fd(::open(partial.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644));
    if (fd.get() < 0) fail(partial, "cannot create");
    try {
      write_all(fd.get(), bytes, partial);
      if (::fsync(fd.get()) != 0) fail(partial, "cannot sync");
      if (::close(fd.release()) != 0) fail(partial, "cannot close");
    } catch (...) {
      std::error_code ignored;
      std::filesystem::remove(partial, ignored);
      throw;
    }
  }
  if (::rename(partial.c_str(), path.c_str()) != 0) {
    const int error = errno;
    std::error_code ignored;
    std::filesystem::remove(partial, ignored);
    errno = error;
    fail(path, "cannot rename " + partial.filename().string() + " over it");
  }
  const std::filesystem::path folder = path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");
  FileDescriptor directory(::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  // The file is complete and in place; a folder that cannot be synced (some file systems) only
  // weakens the crash guarantee, so it is not an error.
  if (directory.get() >= 0) (void)::fsync(directory.get());
}

}  // namespace cmm::planner
