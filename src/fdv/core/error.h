#pragma once
/// Errors at the API boundary. Every message names the file, the position in it (byte offset,
/// line, or key) and the reason, so a user can act on it.
/// Thread safety: immutable once thrown; may be read from any thread.
#include <stdexcept>
#include <string>

namespace fdv {

class InputError : public std::runtime_error {
 public:
  /// `where` is e.g. "byte 1234", "line 17" or "key event_camera.intrinsics"; may be empty.
  InputError(const std::string& file, const std::string& where, const std::string& reason)
      : std::runtime_error(file + (where.empty() ? "" : ":" + where) + ": " + reason),
        file_(file),
        where_(where),
        reason_(reason) {}
  const std::string& file() const { return file_; }
  const std::string& where() const { return where_; }
  const std::string& reason() const { return reason_; }

 private:
  std::string file_, where_, reason_;
};

/// An invalid option or parameter value (configuration, not a file's content).
class ConfigError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

}  // namespace fdv
