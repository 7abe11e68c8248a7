// Formats FileError messages as "file: where: what".
#include "geometry/file_error.hpp"

#include <cstring>

namespace cmm::geometry {

FileError FileError::at_line(const std::filesystem::path& file, std::size_t line, const std::string& message) {
  return FileError(file, file.string() + ": line " + std::to_string(line) + ": " + message);
}

FileError FileError::at_byte(const std::filesystem::path& file, std::uint64_t offset, const std::string& message) {
  return FileError(file, file.string() + ": byte " + std::to_string(offset) + ": " + message);
}

FileError FileError::whole(const std::filesystem::path& file, const std::string& message) {
  return FileError(file, file.string() + ": " + message);
}

FileError FileError::system(const std::filesystem::path& file, const std::string& step, int error_number) {
  return FileError(file, file.string() + ": " + step + ": " + std::strerror(error_number), error_number);
}

}  // namespace cmm::geometry
