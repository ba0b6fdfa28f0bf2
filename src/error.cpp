// meshcvt: error messages with file positions.
#include "meshcvt/error.h"

#include <utility>

namespace meshcvt {

static std::string format_file_error(const std::string& file, FileError::Where where, uint64_t position,
                                     const std::string& reason) {
  switch (where) {
    case FileError::Where::line:
      return file + ":" + std::to_string(position) + ": " + reason;
    case FileError::Where::byte:
      return file + ": byte " + std::to_string(position) + ": " + reason;
    case FileError::Where::none:
      break;
  }
  return file + ": " + reason;
}

FileError::FileError(std::string file, Where where, uint64_t position, std::string reason)
    : Error(format_file_error(file, where, position, reason)),
      file_(std::move(file)),
      reason_(std::move(reason)),
      where_(where),
      position_(position) {}

FileError::FileError(std::string file, std::string reason)
    : FileError(std::move(file), Where::none, 0, std::move(reason)) {}

FileError FileError::at_line(std::string file, uint64_t line, std::string reason) {
  return FileError(std::move(file), Where::line, line, std::move(reason));
}

FileError FileError::at_byte(std::string file, uint64_t byte, std::string reason) {
  return FileError(std::move(file), Where::byte, byte, std::move(reason));
}

DeviceError::DeviceError(const std::string& reason, const std::string& advice)
    : Error(advice.empty() ? reason : reason + "; " + advice), reason_(reason), advice_(advice) {}

}  // namespace meshcvt
