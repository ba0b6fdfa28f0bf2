// meshcvt: the exceptions the library throws. Every failure a user can cause (a bad file, a bad
// option, a missing GPU) is one of these, with a one-line message fit to print as is.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

namespace meshcvt {

/// Base of every meshcvt error.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A file that cannot be read or written, or whose content is malformed.
/// what() reads "FILE:LINE: REASON" for text (line is 1-based), "FILE: byte OFFSET: REASON" for
/// binary data, or "FILE: REASON" when no position applies.
class FileError : public Error {
 public:
  enum class Where { none, line, byte };
  FileError(std::string file, std::string reason);
  static FileError at_line(std::string file, uint64_t line, std::string reason);
  static FileError at_byte(std::string file, uint64_t byte, std::string reason);

  const std::string& file() const { return file_; }
  const std::string& reason() const { return reason_; }
  Where where() const { return where_; }
  uint64_t position() const { return position_; }  ///< line (1-based) or byte offset

 private:
  FileError(std::string file, Where where, uint64_t position, std::string reason);
  std::string file_, reason_;
  Where where_ = Where::none;
  uint64_t position_ = 0;
};

/// Options or arguments that cannot work together (e.g. more clusters than faces). CLI exit code 2
/// when it comes from the command line itself, 1 otherwise.
class OptionError : public Error {
 public:
  using Error::Error;
};

/// No usable compute device, out of device memory, device lost, a missing Vulkan feature.
/// what() reads "REASON" or "REASON; ADVICE": the advice says what a user can do about it ("try
/// --device cpu"). A caller that acts on the error itself (cluster()'s fall back to the CPU engine)
/// reports reason() alone.
class DeviceError : public Error {
 public:
  explicit DeviceError(const std::string& reason, const std::string& advice = {});

  const std::string& reason() const { return reason_; }  ///< what failed, without the advice
  const std::string& advice() const { return advice_; }  ///< what to do about it; may be empty

 private:
  std::string reason_, advice_;
};

}  // namespace meshcvt
