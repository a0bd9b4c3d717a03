#include "fdv/sim/event_labels.h"

#include <bit>
#include <cstring>
#include <filesystem>

#include "fdv/core/error.h"

namespace fdv::sim {

static_assert(std::endian::native == std::endian::little, "event_labels.bin is little-endian");

EventLabelWriter::EventLabelWriter(const std::string& path) : path_(path) {
  out_.open(path, std::ios::binary);
  if (!out_) throw InputError(path, "", "cannot create file");
  char header[16] = {};
  std::memcpy(header, kLabelsMagic, 8);
  out_.write(header, sizeof header);
}

EventLabelWriter::~EventLabelWriter() {
  if (!finished_) {
    try {
      finish();
    } catch (...) {  // destructors must not throw; an explicit finish() reports errors
    }
  }
}

void EventLabelWriter::append(std::span<const std::int16_t> labels) {
  out_.write(reinterpret_cast<const char*>(labels.data()),
             static_cast<std::streamsize>(labels.size_bytes()));
  count_ += labels.size();
}

void EventLabelWriter::finish() {
  if (finished_) return;
  finished_ = true;
  out_.seekp(8);
  out_.write(reinterpret_cast<const char*>(&count_), 8);
  out_.close();
  if (out_.fail()) throw InputError(path_, "", "write failed (disk full?)");
}

std::vector<std::int16_t> read_event_labels(const std::string& dataset_dir) {
  const std::string path = (std::filesystem::path(dataset_dir) / kLabelsFile).string();
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot open");
  char header[16];
  in.read(header, sizeof header);
  if (in.gcount() != 16) throw InputError(path, "byte 0", "truncated header");
  if (std::memcmp(header, kLabelsMagic, 8) != 0)
    throw InputError(path, "byte 0", "wrong magic (expected FDVLBL01)");
  std::uint64_t count;
  std::memcpy(&count, header + 8, 8);
  const auto bytes = std::filesystem::file_size(path) - 16;
  if (bytes < count * 2)
    throw InputError(path, "byte " + std::to_string(16 + bytes),
                     "file ends before its " + std::to_string(count) + " labels");
  std::vector<std::int16_t> labels(count);
  in.read(reinterpret_cast<char*>(labels.data()), static_cast<std::streamsize>(count * 2));
  return labels;
}

}  // namespace fdv::sim
