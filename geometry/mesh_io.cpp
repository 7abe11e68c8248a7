// The file is mapped into memory and parsed from there; every mesh then gets the same clean-up,
// whatever its format.
#include "geometry/mesh_io.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <functional>
#include <sstream>
#include <string>
#include <string_view>

#include "geometry/atomic_file.hpp"
#include "geometry/file_error.hpp"
#include "geometry/mesh_cleanup.hpp"
#include "geometry/obj_io.hpp"
#include "geometry/off_io.hpp"
#include "geometry/pcd_io.hpp"
#include "geometry/ply_io.hpp"
#include "geometry/stl_io.hpp"
#include "geometry/text_io.hpp"
#include "geometry/xyz_io.hpp"

namespace cmm::geometry {

namespace {

struct Format {
  std::string_view extension;
  ReadResult (*read)(const std::filesystem::path&, std::string_view);
  void (*write_mesh)(std::ostream&, const TriangleMesh&);  // null: the format holds no faces
  void (*write_cloud)(std::ostream&, const PointCloud&);   // null: the format holds only faces
};

constexpr Format formats[] = {
    {".stl", read_stl, write_stl, nullptr},
    {".ply", read_ply, [](std::ostream& out, const TriangleMesh& mesh) { write_ply(out, mesh); },
     [](std::ostream& out, const PointCloud& cloud) { write_ply(out, cloud); }},
    {".obj", read_obj, write_obj, write_obj},
    {".off", read_off, write_off, write_off},
    {".xyz", read_xyz, nullptr, write_xyz},
    {".asc", read_xyz, nullptr, write_xyz},  // the same text under the name many scanners export it as
    {".pcd", read_pcd, nullptr, [](std::ostream& out, const PointCloud& cloud) { write_pcd(out, cloud); }},
};

const Format& format_of(const std::filesystem::path& file) {
  std::string extension = file.extension().string();
  std::ranges::transform(extension, extension.begin(), [](unsigned char c) { return std::tolower(c); });
  for (const Format& format : formats) {
    if (format.extension == extension) return format;
  }
  throw FileError::whole(file,
                         "unknown extension " + in_quotes(extension) + "; expected .stl, .ply, .obj, .off, .xyz, .asc or .pcd");
}

// The file mapped read-only and pre-faulted: no copy, and no zero-filled buffer to write first.
class MappedFile {
 public:
  explicit MappedFile(const std::filesystem::path& file) {
    const auto failed = [&](const char* doing) {
      return FileError::whole(file, std::string("cannot ") + doing + ": " + std::strerror(errno));
    };
    struct Descriptor {
      int fd;
      ~Descriptor() {
        if (fd >= 0) ::close(fd);
      }
    } in{::open(file.c_str(), O_RDONLY | O_CLOEXEC)};
    if (in.fd < 0) throw failed("open");
    struct stat status {};
    if (::fstat(in.fd, &status) != 0) throw failed("read");
    if (!S_ISREG(status.st_mode)) throw FileError::whole(file, "cannot read: not a regular file");
    size_ = static_cast<std::size_t>(status.st_size);
    if (size_ == 0) return;
    data_ = ::mmap(nullptr, size_, PROT_READ, MAP_PRIVATE | MAP_POPULATE, in.fd, 0);
    if (data_ == MAP_FAILED) throw failed("read");
  }
  ~MappedFile() {
    if (data_ != MAP_FAILED) ::munmap(data_, size_);
  }
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;

  std::string_view bytes() const {
    return data_ == MAP_FAILED ? std::string_view() : std::string_view(static_cast<const char*>(data_), size_);
  }

 private:
  void* data_ = MAP_FAILED;
  std::size_t size_ = 0;
};

// Written whole in memory first, then atomically: a failed write never leaves half a mesh.
void write_file(const std::filesystem::path& file, const std::function<void(std::ostream&)>& write) {
  std::ostringstream out(std::ios::binary);
  write(out);
  write_atomically(file, out.str());
}

}  // namespace

std::vector<std::string> model_extensions() {
  std::vector<std::string> extensions;
  for (const Format& format : formats) extensions.emplace_back(format.extension);
  return extensions;
}

ReadResult read_model(const std::filesystem::path& file) {
  const Format& format = format_of(file);
  const MappedFile mapped(file);
  ReadResult result = format.read(file, mapped.bytes());
  if (result.report.vertices_read == 0) throw FileError::whole(file, "holds no vertices");
  if (auto* mesh = std::get_if<TriangleMesh>(&result.model)) drop_bad_faces(*mesh, result.report);
  return result;
}

TriangleMesh read_mesh(const std::filesystem::path& file, ReadReport* report) {
  ReadResult result = read_model(file);
  if (const auto* cloud = std::get_if<PointCloud>(&result.model)) {
    throw FileError::whole(
        file, "holds a point cloud (" + std::to_string(cloud->points.rows()) + " points, no faces), not a mesh");
  }
  if (report != nullptr) *report = result.report;
  return std::get<TriangleMesh>(std::move(result.model));
}

void write_mesh(const std::filesystem::path& file, const TriangleMesh& mesh) {
  const Format& format = format_of(file);
  if (format.write_mesh == nullptr) {
    throw FileError::whole(
        file, in_quotes(format.extension) + " holds points only, not a mesh; use .stl, .ply, .obj or .off");
  }
  write_file(file, [&](std::ostream& out) { format.write_mesh(out, mesh); });
}

void write_cloud(const std::filesystem::path& file, const PointCloud& cloud) {
  const Format& format = format_of(file);
  if (format.write_cloud == nullptr) {
    throw FileError::whole(
        file, in_quotes(format.extension) + " holds triangles only, not a point cloud; use .ply, .obj, .off, .xyz, .asc or .pcd");
  }
  write_file(file, [&](std::ostream& out) { format.write_cloud(out, cloud); });
}

}  // namespace cmm::geometry
