#pragma once
/// Cursors over one serialized ROS message, for the two wire formats the bag readers decode:
///
///   Ros1Cursor: ROS 1 serialization. Little-endian, packed (no alignment). `time` is uint32 sec +
///               uint32 nsec; strings and variable arrays are a uint32 count then the elements.
///   CdrCursor:  ROS 2's CDR (OMG XCDR version 1). A 4-byte encapsulation header (0x00 0x00 big
///               endian, 0x00 0x01 little endian; two option bytes), then the payload, in which
///               every primitive of size n (1, 2, 4, 8) starts at an offset that is a multiple
///               of n counted from the payload start (the byte after the encapsulation header).
///               builtin_interfaces/Time is int32 sec + uint32 nanosec; a string is a uint32
///               length that counts the terminating NUL, the bytes, and the NUL; a sequence is a
///               uint32 count then the elements; fixed arrays have no count.
///
/// Both cursors have the same interface so that one decoder template serves both bag kinds.
/// Reading past the end never reads out of bounds: it sets ok() to false and returns zeros, and
/// the decoder checks ok() once at the end (no exceptions or allocation per field).
/// Thread safety: a cursor is used by one thread; the bytes it reads must not change meanwhile.
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string_view>

#include "fdv/core/time.h"

namespace fdv::bag {

/// Reverses the bytes of an unsigned integer (byte_swap is C++23).
template <typename U>
constexpr U byte_swap(U u) {
  static_assert(sizeof(U) == 2 || sizeof(U) == 4 || sizeof(U) == 8);
  if constexpr (sizeof(U) == 2) return static_cast<U>(__builtin_bswap16(u));
  if constexpr (sizeof(U) == 4) return static_cast<U>(__builtin_bswap32(u));
  if constexpr (sizeof(U) == 8) return static_cast<U>(__builtin_bswap64(u));
}

/// Common bounds-checked byte access.
class CursorBase {
 public:
  CursorBase(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  bool ok() const { return ok_; }
  std::size_t offset() const { return pos_; }
  std::size_t remaining() const { return ok_ ? size_ - pos_ : 0; }
  /// `n` raw bytes (nullptr and !ok() if fewer remain).
  const std::uint8_t* bytes(std::size_t n) {
    if (!ok_ || n > size_ - pos_) {
      ok_ = false;
      return nullptr;
    }
    const std::uint8_t* p = data_ + pos_;
    pos_ += n;
    return p;
  }
  void fail() { ok_ = false; }

 protected:
  template <typename T>
  T load(bool big_endian) {
    const std::uint8_t* p = bytes(sizeof(T));
    if (!p) return T{};
    if constexpr (sizeof(T) == 1) {
      T v;
      std::memcpy(&v, p, 1);
      return v;
    } else {
      using U =
          std::conditional_t<sizeof(T) == 2, std::uint16_t,
                             std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>>;
      U u;
      std::memcpy(&u, p, sizeof u);
      if (big_endian != (std::endian::native == std::endian::big)) u = byte_swap(u);
      T v;
      std::memcpy(&v, &u, sizeof v);
      return v;
    }
  }

  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
  bool ok_ = true;
};

class Ros1Cursor : public CursorBase {
 public:
  using CursorBase::CursorBase;
  template <typename T>
  T get() {
    return load<T>(false);
  }
  /// ROS 1 `time`: uint32 sec, uint32 nsec.
  TimeNs time() {
    const std::uint32_t sec = get<std::uint32_t>();
    const std::uint32_t nsec = get<std::uint32_t>();
    return static_cast<TimeNs>(sec) * kNsPerS + nsec;
  }
  std::string_view string() {
    const std::uint32_t n = get<std::uint32_t>();
    const std::uint8_t* p = bytes(n);
    return p ? std::string_view(reinterpret_cast<const char*>(p), n) : std::string_view{};
  }
  /// Count of a variable-length array whose elements take at least `min_element_bytes`
  /// (guards against a corrupt count promising more than the message holds).
  std::uint32_t sequence(std::size_t min_element_bytes) {
    const std::uint32_t n = get<std::uint32_t>();
    if (min_element_bytes > 0 && n > remaining() / min_element_bytes) fail();
    return ok() ? n : 0;
  }
  /// std_msgs/Header: uint32 seq, time stamp, string frame_id. Returns the stamp.
  TimeNs header() {
    (void)get<std::uint32_t>();
    const TimeNs stamp = time();
    (void)string();
    return stamp;
  }
  void skip_doubles(std::size_t n) { (void)bytes(8 * n); }
};

class CdrCursor : public CursorBase {
 public:
  static constexpr std::size_t kEncapsulationBytes = 4;
  /// Reads the encapsulation header; ok() is false for a payload that is too short or not plain
  /// CDR (XCDR2 and parameter-list encodings are not what ROS 2 bags store).
  CdrCursor(const std::uint8_t* data, std::size_t size) : CursorBase(data, size) {
    const std::uint8_t* h = bytes(kEncapsulationBytes);
    if (!h || h[0] != 0 || h[1] > 1) {
      fail();
      return;
    }
    big_endian_ = h[1] == 0;
  }
  bool big_endian() const { return big_endian_; }

  template <typename T>
  T get() {
    align(sizeof(T));
    return load<T>(big_endian_);
  }
  /// builtin_interfaces/Time: int32 sec, uint32 nanosec.
  TimeNs time() {
    const std::int32_t sec = get<std::int32_t>();
    const std::uint32_t nsec = get<std::uint32_t>();
    return static_cast<TimeNs>(sec) * kNsPerS + nsec;
  }
  /// The string without its terminating NUL.
  std::string_view string() {
    const std::uint32_t n = get<std::uint32_t>();
    const std::uint8_t* p = bytes(n);
    if (!p) return {};
    return std::string_view(reinterpret_cast<const char*>(p), n > 0 && p[n - 1] == 0 ? n - 1 : n);
  }
  std::uint32_t sequence(std::size_t min_element_bytes) {
    const std::uint32_t n = get<std::uint32_t>();
    if (min_element_bytes > 0 && n > remaining() / min_element_bytes) fail();
    return ok() ? n : 0;
  }
  /// std_msgs/msg/Header: Time stamp, string frame_id. Returns the stamp.
  TimeNs header() {
    const TimeNs stamp = time();
    (void)string();
    return stamp;
  }
  void skip_doubles(std::size_t n) {
    align(8);
    (void)bytes(8 * n);
  }
  /// Moves to the next multiple of n from the payload start.
  void align(std::size_t n) {
    if (n <= 1 || !ok_) return;
    const std::size_t rel = pos_ - kEncapsulationBytes;
    const std::size_t pad = (n - rel % n) % n;
    (void)bytes(pad);
  }

 private:
  bool big_endian_ = false;
};

}  // namespace fdv::bag
