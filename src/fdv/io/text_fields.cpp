#include "fdv/io/text_fields.h"

#include <charconv>
#include <cmath>
#include <fstream>

#include "fdv/core/config_text.h"
#include "fdv/core/error.h"

namespace fdv {
namespace {
std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}
}  // namespace

LineReader::LineReader(const std::string& path)
    : path_(path), in_(std::make_unique<std::ifstream>(check_regular_file(path), std::ios::binary)) {
  if (!*in_) throw InputError(path, "", "cannot open file");
}

LineReader::LineReader(std::unique_ptr<std::istream> in, std::string name)
    : path_(std::move(name)), in_(std::move(in)) {
  if (!in_ || !*in_) throw InputError(path_, "", "cannot read");
}

bool LineReader::next(std::string_view& line) {
  buffer_.resize(kMaxLineBytes + 1);
  while (true) {
    in_->getline(buffer_.data(), static_cast<std::streamsize>(buffer_.size()));
    const auto got = static_cast<std::size_t>(in_->gcount());
    if (got == 0 && in_->eof()) return false;  // nothing left
    ++line_number_;
    if (in_->bad()) throw InputError(path_, where(), "read error");
    // failbit without eof: the buffer filled before a newline came.
    if (in_->fail() && !in_->eof())
      throw InputError(path_, where(),
                       "line longer than " + std::to_string(kMaxLineBytes) + " bytes");
    // gcount counts the newline when one was extracted.
    const std::size_t length = in_->eof() ? got : got - 1;
    line = trim(std::string_view(buffer_.data(), length));
    if (!line.empty() && line.front() != '#') return true;
    if (in_->eof()) return false;
  }
}

void split_fields(std::string_view line, char separator, std::vector<std::string_view>& fields) {
  fields.clear();
  if (separator == ' ') {
    std::size_t i = 0;
    while (i < line.size()) {
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
      std::size_t j = i;
      while (j < line.size() && line[j] != ' ' && line[j] != '\t') ++j;
      if (j > i) fields.push_back(line.substr(i, j - i));
      i = j;
    }
    return;
  }
  std::size_t start = 0;
  while (true) {
    const std::size_t end = line.find(separator, start);
    fields.push_back(trim(line.substr(start, end == std::string_view::npos ? line.npos : end - start)));
    if (end == std::string_view::npos) break;
    start = end + 1;
  }
}

bool parse_int64(std::string_view s, std::int64_t& out) {
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && ptr == s.data() + s.size() && !s.empty();
}

bool parse_double(std::string_view s, double& out) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && ptr == s.data() + s.size() && !s.empty() && std::isfinite(out);
}

bool parse_seconds_to_ns(std::string_view s, TimeNs& out) {
  if (s.empty()) return false;
  bool negative = false;
  if (s.front() == '-' || s.front() == '+') {
    negative = s.front() == '-';
    s.remove_prefix(1);
  }
  const std::size_t dot = s.find('.');
  const std::string_view whole = s.substr(0, dot);
  std::string_view frac = dot == std::string_view::npos ? std::string_view{} : s.substr(dot + 1);
  std::int64_t sec = 0;
  // One sign only: parse_int64 would take a second '-'.
  if (!whole.empty() && (whole.front() < '0' || whole.front() > '9')) return false;
  if (!whole.empty() && !parse_int64(whole, sec)) return false;
  if (whole.empty() && frac.empty()) return false;
  std::int64_t ns = 0;
  int digits = 0;
  bool round_up = false;
  for (std::size_t i = 0; i < frac.size(); ++i) {
    const char c = frac[i];
    if (c < '0' || c > '9') return false;
    if (digits < 9) {
      ns = ns * 10 + (c - '0');
      ++digits;
    } else if (i == 9) {
      round_up = c >= '5';
    }
  }
  for (; digits < 9; ++digits) ns *= 10;
  // Beyond int64 nanoseconds (about 292 years from the epoch) is not a time.
  const auto sec_ns = checked_mul(sec, kNsPerS);
  const auto total = sec_ns ? checked_add(*sec_ns, ns + (round_up ? 1 : 0)) : std::nullopt;
  if (!total) return false;
  out = negative ? -*total : *total;
  return true;
}

std::string escape_non_utf8(std::string_view text) {
  // Length of the well-formed UTF-8 sequence at text[i], 0 if there is none (Unicode 15, Table
  // 3-7: no overlong forms, no surrogates, nothing above U+10FFFF).
  const auto sequence_length = [&](std::size_t i) -> std::size_t {
    const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(text[k]); };
    const unsigned char b0 = byte(i);
    if (b0 < 0x80) return 1;
    std::size_t n;
    unsigned char low = 0x80, high = 0xBF;  // range of the second byte
    if (b0 >= 0xC2 && b0 <= 0xDF) n = 2;
    else if (b0 >= 0xE0 && b0 <= 0xEF) n = 3, low = b0 == 0xE0 ? 0xA0 : 0x80, high = b0 == 0xED ? 0x9F : 0xBF;
    else if (b0 >= 0xF0 && b0 <= 0xF4) n = 4, low = b0 == 0xF0 ? 0x90 : 0x80, high = b0 == 0xF4 ? 0x8F : 0xBF;
    else return 0;
    if (i + n > text.size() || byte(i + 1) < low || byte(i + 1) > high) return 0;
    for (std::size_t k = 2; k < n; ++k)
      if (byte(i + k) < 0x80 || byte(i + k) > 0xBF) return 0;
    return n;
  };
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size();) {
    if (const std::size_t n = sequence_length(i)) {
      out.append(text.substr(i, n));
      i += n;
    } else {
      static constexpr char kHex[] = "0123456789ABCDEF";
      const auto b = static_cast<unsigned char>(text[i++]);
      out += "\\x";
      out += kHex[b >> 4];
      out += kHex[b & 0xF];
    }
  }
  return out;
}

}  // namespace fdv
