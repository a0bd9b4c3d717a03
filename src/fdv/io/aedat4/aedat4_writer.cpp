#include "fdv/io/aedat4/aedat4_writer.h"

#include <flatbuffers/flatbuffers.h>
#include <lz4frame.h>
#include <zstd.h>

#include <cmath>
#include <limits>

#include "fdv/core/error.h"
#include "fdv/io/aedat4/event_packet_generated.h"
#include "fdv/io/aedat4/imu_packet_generated.h"
#include "fdv/io/aedat4/io_header_generated.h"

namespace fdv {
namespace {

constexpr std::int32_t kEventsStream = 0, kImuStream = 1;
constexpr int kMaxSide = std::numeric_limits<std::int16_t>::max();

const char* compression_name(Aedat4Compression c) {
  return c == Aedat4Compression::kLz4 ? "LZ4" : c == Aedat4Compression::kZstd ? "ZSTD" : "NONE";
}

/// The IOHeader's stream description, in the layout DV's recorder writes.
std::string info_xml(int width, int height, Aedat4Compression c) {
  const auto stream = [&](int id, const char* name, const char* type, const char* description,
                          const std::string& info) {
    const std::string path = "/fdv/outInfo/" + std::to_string(id) + "/";
    return "<node name=\"" + std::to_string(id) + "\" path=\"" + path + "\">" +
           "<attr key=\"compression\" type=\"string\">" + compression_name(c) + "</attr>" +
           "<attr key=\"originalModuleName\" type=\"string\">fdv</attr>" +
           "<attr key=\"originalOutputName\" type=\"string\">" + name + "</attr>" +
           "<attr key=\"typeDescription\" type=\"string\">" + description + "</attr>" +
           "<attr key=\"typeIdentifier\" type=\"string\">" + type + "</attr>" + "<node name=\"info\" path=\"" +
           path + "info/\">" + info + "<attr key=\"source\" type=\"string\">fdv</attr>" +
           "<attr key=\"tsOffset\" type=\"long\">0</attr></node></node>";
  };
  const std::string size = "<attr key=\"sizeX\" type=\"int\">" + std::to_string(width) +
                           "</attr><attr key=\"sizeY\" type=\"int\">" + std::to_string(height) + "</attr>";
  return "<dv version=\"2.0\"><node name=\"outInfo\" path=\"/fdv/outInfo/\">" +
         stream(kEventsStream, "events", "EVTS", "Array of events (polarity ON/OFF).", size) +
         stream(kImuStream, "imu", "IMUS", "Inertial Measurement Unit data samples.", "") + "</node></dv>";
}

}  // namespace

Aedat4Writer::Aedat4Writer(const std::string& path, int width, int height, Aedat4Compression compression)
    : path_(path), width_(width), height_(height), compression_(compression) {
  if (width < 1 || height < 1 || width > kMaxSide || height > kMaxSide)
    throw ConfigError(path + ": AEDAT 4.0 addresses pixels with int16: sensor size " + std::to_string(width) + "x" +
                      std::to_string(height) + " is outside 1..32767");
  if (compression != Aedat4Compression::kNone && compression != Aedat4Compression::kLz4 &&
      compression != Aedat4Compression::kZstd)
    throw ConfigError(path + ": the AEDAT 4.0 writer compresses with none, LZ4 or Zstd");
  out_.open(path, std::ios::binary | std::ios::trunc);
  if (!out_) throw InputError(path, "", "cannot create the file");
  flatbuffers::FlatBufferBuilder b;
  b.FinishSizePrefixed(aedat4::fb::CreateIOHeaderDirect(b, static_cast<aedat4::fb::CompressionType>(compression), -1,
                                                         info_xml(width, height, compression).c_str()),
                       aedat4::fb::IOHeaderIdentifier());
  out_.write(kAedat4Magic.data(), static_cast<std::streamsize>(kAedat4Magic.size()));
  out_.write(reinterpret_cast<const char*>(b.GetBufferPointer()), static_cast<std::streamsize>(b.GetSize()));
  if (!out_) throw InputError(path, "", "write failed (disk full?)");
}

Aedat4Writer::~Aedat4Writer() {
  try {
    close();
  } catch (...) {  // a destructor must not throw; close() explicitly to see the error
  }
}

std::int64_t Aedat4Writer::checked_us(TimeNs t, TimeNs& last, std::uint64_t index, const char* what) {
  if (t < last)
    throw InputError(path_, std::string(what) + " " + std::to_string(index),
                     "time goes backwards (" + std::to_string(t) + " ns after " + std::to_string(last) + " ns)");
  last = t;
  const std::int64_t us = floor_us(t);
  if (us * 1000 != t) ++floored_;
  return us;
}

void Aedat4Writer::add(std::span<const Event> events) {
  if (closed_) throw ConfigError(path_ + ": add() after close()");
  std::vector<aedat4::fb::Event> packet;
  for (std::size_t begin = 0; begin < events.size(); begin += kAedat4WriterPacketEvents) {
    const auto part = events.subspan(begin, std::min(kAedat4WriterPacketEvents, events.size() - begin));
    packet.clear();
    for (const Event& e : part) {
      if (e.x >= width_ || e.y >= height_)
        throw InputError(path_, "event " + std::to_string(events_),
                         "pixel (" + std::to_string(e.x) + ", " + std::to_string(e.y) + ") outside the " +
                             std::to_string(width_) + "x" + std::to_string(height_) + " sensor");
      packet.emplace_back(checked_us(e.t, last_event_t_, events_, "event"), static_cast<std::int16_t>(e.x),
                          static_cast<std::int16_t>(e.y), e.polarity);
      ++events_;
    }
    flatbuffers::FlatBufferBuilder b(packet.size() * sizeof(aedat4::fb::Event) + 64);
    b.FinishSizePrefixed(aedat4::fb::CreateEventPacketDirect(b, &packet), aedat4::fb::EventPacketIdentifier());
    write_packet(kEventsStream, {b.GetBufferPointer(), b.GetSize()});
  }
}

void Aedat4Writer::add(std::span<const ImuSample> imu) {
  if (closed_) throw ConfigError(path_ + ": add() after close()");
  constexpr float kUnknown = std::numeric_limits<float>::quiet_NaN();
  for (std::size_t begin = 0; begin < imu.size(); begin += kAedat4WriterPacketEvents) {
    const auto part = imu.subspan(begin, std::min(kAedat4WriterPacketEvents, imu.size() - begin));
    flatbuffers::FlatBufferBuilder b;
    std::vector<flatbuffers::Offset<aedat4::fb::Imu>> samples;
    for (const ImuSample& s : part) {
      const Eigen::Vector3f a = (s.accel_m_s2 / kAedat4Gravity_m_s2).cast<float>();
      const Eigen::Vector3f w = (s.gyro_rad_s / kAedat4RadPerDeg).cast<float>();
      samples.push_back(aedat4::fb::CreateImu(b, checked_us(s.t, last_imu_t_, imu_, "IMU sample"), kUnknown, a.x(),
                                              a.y(), a.z(), w.x(), w.y(), w.z(), kUnknown, kUnknown, kUnknown));
      ++imu_;
    }
    b.FinishSizePrefixed(aedat4::fb::CreateImuPacketDirect(b, &samples), aedat4::fb::ImuPacketIdentifier());
    write_packet(kImuStream, {b.GetBufferPointer(), b.GetSize()});
  }
}

void Aedat4Writer::write_packet(std::int32_t stream, std::span<const std::uint8_t> flatbuffer) {
  std::span<const std::uint8_t> payload = flatbuffer;
  if (compression_ == Aedat4Compression::kLz4) {
    packed_.resize(LZ4F_compressFrameBound(flatbuffer.size(), nullptr));
    const std::size_t n = LZ4F_compressFrame(packed_.data(), packed_.size(), flatbuffer.data(), flatbuffer.size(), nullptr);
    if (LZ4F_isError(n)) throw InputError(path_, "", std::string("LZ4 compression failed: ") + LZ4F_getErrorName(n));
    payload = {packed_.data(), n};
  } else if (compression_ == Aedat4Compression::kZstd) {
    packed_.resize(ZSTD_compressBound(flatbuffer.size()));
    const std::size_t n = ZSTD_compress(packed_.data(), packed_.size(), flatbuffer.data(), flatbuffer.size(), 3);
    if (ZSTD_isError(n)) throw InputError(path_, "", std::string("Zstd compression failed: ") + ZSTD_getErrorName(n));
    payload = {packed_.data(), n};
  }
  const std::int32_t header[2] = {stream, static_cast<std::int32_t>(payload.size())};
  out_.write(reinterpret_cast<const char*>(header), sizeof header);
  out_.write(reinterpret_cast<const char*>(payload.data()), static_cast<std::streamsize>(payload.size()));
  if (!out_) throw InputError(path_, "", "write failed (disk full?)");
}

void Aedat4Writer::close() {
  if (closed_) return;
  closed_ = true;
  out_.close();
  if (!out_) throw InputError(path_, "", "write failed on close");
}

}  // namespace fdv
