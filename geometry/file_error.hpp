// The error every file reader and writer throws: it names the file and where in it things went
// wrong, so an operator can open the file at that line or byte and see the problem. (A JSON input's
// bad fields are description::FieldError, which names each by its JSON Pointer.)
#pragma once

#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>

namespace cmm::geometry {

class FileError : public std::runtime_error {
 public:
  // what() reads "part.ply: line 12: face index 9999 out of range (6475 vertices)".
  static FileError at_line(const std::filesystem::path& file, std::size_t line, const std::string& message);
  static FileError at_byte(const std::filesystem::path& file, std::uint64_t offset, const std::string& message);
  static FileError whole(const std::filesystem::path& file, const std::string& message);
  // A system call on the file failed: "touches.jsonl: append: No space left on device", and the
  // errno kept, so a caller can tell a full disk (ENOSPC, EDQUOT) from a broken one.
  static FileError system(const std::filesystem::path& file, const std::string& step, int error_number);

  const std::filesystem::path& file() const { return file_; }
  int error_number() const { return error_number_; }            // errno of the failed call; 0 when none

 private:
  FileError(std::filesystem::path file, const std::string& full_message, int error_number = 0)
      : std::runtime_error(full_message), file_(std::move(file)), error_number_(error_number) {}
  std::filesystem::path file_;
  int error_number_ = 0;
};

}  // namespace cmm::geometry
