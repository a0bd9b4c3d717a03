#include "fdv/io/prophesee/evt3_writer.h"

#include "fdv/core/error.h"

namespace fdv {
namespace {

// EVT 3.0 word types (Prophesee's format page): bits 15..12.
constexpr unsigned kAddrY = 0x0;     // y in bits 10..0
constexpr unsigned kAddrX = 0x2;     // polarity in bit 11, x in bits 10..0: one event
constexpr unsigned kTimeLow = 0x6;   // time bits 11..0 [µs]
constexpr unsigned kTimeHigh = 0x8;  // time bits 23..12 [µs]
constexpr std::int64_t kPeriodUs = 1 << 12;
constexpr std::size_t kFlushWords = 1 << 16;

}  // namespace

Evt3Writer::Evt3Writer(const std::string& path, int width, int height)
    : path_(path), width_(width), height_(height) {
  if (width < 1 || height < 1 || width > kEvt3MaxSide || height > kEvt3MaxSide)
    throw ConfigError(path + ": EVT 3.0 addresses pixels with 11 bits: sensor size " + std::to_string(width) +
                      "x" + std::to_string(height) + " is outside 1..2048");
  out_.open(path, std::ios::binary | std::ios::trunc);
  if (!out_) throw InputError(path, "", "cannot create the file");
}

Evt3Writer::~Evt3Writer() {
  try {
    close();
  } catch (...) {  // a destructor must not throw; close() explicitly to see the error
  }
}

void Evt3Writer::write_header(std::int64_t offset_us) {
  const std::string size = std::to_string(width_) + "x" + std::to_string(height_);
  out_ << "% evt 3.0\n% format EVT3;height=" << height_ << ";width=" << width_ << "\n% geometry " << size
       << "\n% time_offset_us " << offset_us << "\n% end\n";
}

void Evt3Writer::add(std::span<const Event> events) {
  if (closed_) throw ConfigError(path_ + ": add() after close()");
  for (const Event& e : events) {
    const std::int64_t abs_us = floor_us(e.t);
    if (!started_) {
      started_ = true;
      first_us_ = abs_us;
      write_header(first_us_);
      word(kTimeHigh, 0);
    }
    const std::int64_t t = abs_us - first_us_;
    if (t < time_us_)
      throw InputError(path_, "event " + std::to_string(count_),
                       "time goes backwards (" + std::to_string(abs_us) + " µs after " +
                           std::to_string(time_us_ + first_us_) + " µs)");
    if (e.x >= width_ || e.y >= height_)
      throw InputError(path_, "event " + std::to_string(count_),
                       "pixel (" + std::to_string(e.x) + ", " + std::to_string(e.y) + ") outside the " +
                           std::to_string(width_) + "x" + std::to_string(height_) + " sensor");
    if (abs_us * 1000 != e.t) ++floored_;
    // Every period boundary crossed gets its TIME_HIGH (bits 23..12 of the relative time).
    while (t >= high_us_ + kPeriodUs) {
      high_us_ += kPeriodUs;
      word(kTimeHigh, static_cast<unsigned>(high_us_ >> 12));
    }
    if (t != time_us_) {
      word(kTimeLow, static_cast<unsigned>(t));
      time_us_ = t;
    }
    if (!have_y_ || e.y != y_) {
      word(kAddrY, e.y);
      y_ = e.y;
      have_y_ = true;
    }
    word(kAddrX, (e.polarity ? 1u << 11 : 0u) | e.x);
    ++count_;
    if (words_.size() >= kFlushWords) flush();
  }
}

void Evt3Writer::flush() {
  out_.write(reinterpret_cast<const char*>(words_.data()),
             static_cast<std::streamsize>(words_.size() * sizeof(std::uint16_t)));
  if (!out_) throw InputError(path_, "", "write failed (disk full?)");
  words_.clear();
}

void Evt3Writer::close() {
  if (closed_) return;
  closed_ = true;
  if (!started_) write_header(0);
  flush();
  out_.close();
  if (!out_) throw InputError(path_, "", "write failed on close");
}

}  // namespace fdv
