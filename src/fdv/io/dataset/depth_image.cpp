// libpng's classic interface (raw sample values: the simplified one applies gamma to 16-bit
// files) with its errors returned through setjmp: only trivially destructible objects live
// between setjmp and the libpng calls that may jump back.
#include "fdv/io/dataset/depth_image.h"

#include <png.h>
#include <zstd.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "fdv/core/error.h"

namespace fdv {
namespace {

// PNG: the 8-byte signature (PNG spec 5.2). Zstandard: the frame magic 0xFD2FB528, little-endian
// (RFC 8878, 3.1.1).
constexpr std::uint8_t kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
constexpr std::uint8_t kZstdMagic[4] = {0x28, 0xB5, 0x2F, 0xFD};
// Level 1: the simulator writes a frame every 33 ms of each throw; higher levels cost time for a
// few per cent of size.
constexpr int kZstdLevel = 1;
constexpr bool kLittleEndian = std::endian::native == std::endian::little;

/// libpng's error and I/O state for one call.
struct PngCall {
  const std::uint8_t* input = nullptr;
  std::size_t input_size = 0, input_at = 0;
  std::vector<std::uint8_t>* output = nullptr;
  char error[160] = "";
};

PngCall& call_of(png_structp png) { return *static_cast<PngCall*>(png_get_error_ptr(png)); }

void on_png_error(png_structp png, png_const_charp message) {
  std::snprintf(call_of(png).error, sizeof call_of(png).error, "%s", message);
  png_longjmp(png, 1);
}
void on_png_warning(png_structp, png_const_charp) {}  // ancillary-chunk trouble: the pixels stand

void read_from_memory(png_structp png, png_bytep out, png_size_t n) {
  PngCall& call = call_of(png);
  if (n > call.input_size - call.input_at) png_error(png, "file ends inside the image");
  std::memcpy(out, call.input + call.input_at, n);
  call.input_at += n;
}

void write_to_memory(png_structp png, png_bytep data, png_size_t n) {
  call_of(png).output->insert(call_of(png).output->end(), data, data + n);
}
void flush_nothing(png_structp) {}

/// Rows to PNG bytes, or to `file` when given. Returns "" or libpng's reason.
std::string write_png(png_bytep* rows, int width, int height, int bit_depth, int colour_type,
                      bool bgr, std::vector<std::uint8_t>* memory, std::FILE* file) {
  PngCall call;
  call.output = memory;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &call, on_png_error, on_png_warning);
  if (png == nullptr) return "out of memory";
  png_infop info = png_create_info_struct(png);
  if (info == nullptr) {
    png_destroy_write_struct(&png, nullptr);
    return "out of memory";
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return call.error;
  }
  if (file != nullptr)
    png_init_io(png, file);
  else
    png_set_write_fn(png, &call, write_to_memory, flush_nothing);
  // Fast deflate with run-length matches, as OpenCV's PNG writer does by default.
  png_set_compression_level(png, 1);
  png_set_compression_strategy(png, 3 /* Z_RLE */);
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height),
               bit_depth, colour_type, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  if (bit_depth == 16 && kLittleEndian) png_set_swap(png);  // PNG samples are big-endian
  if (bgr) png_set_bgr(png);
  png_write_image(png, rows);
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return "";
}

}  // namespace

bool sniff_depth_encoding(std::span<const std::uint8_t> bytes, DepthEncoding& encoding) {
  if (bytes.size() >= sizeof kPngSignature &&
      std::memcmp(bytes.data(), kPngSignature, sizeof kPngSignature) == 0) {
    encoding = DepthEncoding::kPng;
    return true;
  }
  if (bytes.size() >= sizeof kZstdMagic && std::memcmp(bytes.data(), kZstdMagic, sizeof kZstdMagic) == 0) {
    encoding = DepthEncoding::kZstd;
    return true;
  }
  return false;
}

void metres_to_millimetres(std::span<const float> metres, std::span<std::uint16_t> millimetres) {
  std::transform(metres.begin(), metres.end(), millimetres.begin(), [](float d) {
    const double m = std::isfinite(d) && d > 0 ? std::round(d * 1000.0) : 0.0;
    return static_cast<std::uint16_t>(std::min(m, 65535.0));
  });
}

void millimetres_to_metres(std::span<const std::uint16_t> millimetres, std::span<float> metres) {
  std::transform(millimetres.begin(), millimetres.end(), metres.begin(),
                 [](std::uint16_t mm) { return static_cast<float>(mm) * 0.001f; });
}

std::vector<std::uint8_t> encode_depth_png(std::span<const std::uint16_t> millimetres, int width,
                                           int height) {
  if (millimetres.size() != static_cast<std::size_t>(width) * static_cast<std::size_t>(height))
    throw std::invalid_argument("encode_depth_png: pixel count differs from width x height");
  std::vector<png_bytep> rows(static_cast<std::size_t>(height));
  for (int v = 0; v < height; ++v)  // libpng does not write through them
    rows[static_cast<std::size_t>(v)] = reinterpret_cast<png_bytep>(
        const_cast<std::uint16_t*>(millimetres.data() + static_cast<std::size_t>(v) * width));
  std::vector<std::uint8_t> bytes;
  bytes.reserve(millimetres.size_bytes() / 2);
  const std::string error =
      write_png(rows.data(), width, height, 16, PNG_COLOR_TYPE_GRAY, false, &bytes, nullptr);
  if (!error.empty()) throw std::runtime_error("depth PNG: " + error);
  return bytes;
}

std::vector<std::uint8_t> encode_depth_zstd(std::span<const std::uint16_t> millimetres) {
  std::vector<std::uint16_t> swapped;
  if constexpr (!kLittleEndian) {
    swapped.assign(millimetres.begin(), millimetres.end());
    for (std::uint16_t& v : swapped) v = static_cast<std::uint16_t>(v << 8 | v >> 8);
    millimetres = swapped;
  }
  std::vector<std::uint8_t> bytes(ZSTD_compressBound(millimetres.size_bytes()));
  const std::size_t n = ZSTD_compress(bytes.data(), bytes.size(), millimetres.data(),
                                      millimetres.size_bytes(), kZstdLevel);
  if (ZSTD_isError(n)) throw std::runtime_error(std::string("depth Zstandard: ") + ZSTD_getErrorName(n));
  bytes.resize(n);
  return bytes;
}

std::string decode_depth_png(std::span<const std::uint8_t> png_bytes, int width, int height,
                             std::span<std::uint16_t> millimetres) {
  if (width <= 0 || height <= 0 ||
      millimetres.size() != static_cast<std::size_t>(width) * static_cast<std::size_t>(height))
    return "the frame's size is not width x height pixels";
  std::vector<png_bytep> rows(static_cast<std::size_t>(height));
  for (int v = 0; v < height; ++v)
    rows[static_cast<std::size_t>(v)] =
        reinterpret_cast<png_bytep>(millimetres.data() + static_cast<std::size_t>(v) * width);
  PngCall call;
  call.input = png_bytes.data();
  call.input_size = png_bytes.size();
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &call, on_png_error, on_png_warning);
  if (png == nullptr) return "out of memory";
  png_infop info = png_create_info_struct(png);
  if (info == nullptr) {
    png_destroy_read_struct(&png, nullptr, nullptr);
    return "out of memory";
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    return call.error;
  }
  png_set_read_fn(png, &call, read_from_memory);
  // Larger images are refused from their header, before anything is allocated for them.
  png_set_user_limits(png, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height));
  png_read_info(png, info);
  png_uint_32 w = 0, h = 0;
  int bit_depth = 0, colour_type = 0, interlace = 0;
  png_get_IHDR(png, info, &w, &h, &bit_depth, &colour_type, &interlace, nullptr, nullptr);
  if (w != static_cast<png_uint_32>(width) || h != static_cast<png_uint_32>(height))
    png_error(png, "image size differs from its header");
  if (bit_depth != 16 || colour_type != PNG_COLOR_TYPE_GRAY)
    png_error(png, "image is not 16-bit greyscale");
  if (kLittleEndian) png_set_swap(png);
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  png_read_image(png, rows.data());
  png_destroy_read_struct(&png, &info, nullptr);
  return "";
}

std::string decode_depth_zstd(std::span<const std::uint8_t> zstd, std::span<std::uint16_t> millimetres) {
  const unsigned long long declared = ZSTD_getFrameContentSize(zstd.data(), zstd.size());
  if (declared == ZSTD_CONTENTSIZE_ERROR) return "not a Zstandard frame";
  if (declared != ZSTD_CONTENTSIZE_UNKNOWN && declared != millimetres.size_bytes())
    return "frame holds " + std::to_string(declared) + " bytes, not the " +
           std::to_string(millimetres.size_bytes()) + " of the depth camera's image";
  // Bounded by the output's size whatever the frame declares.
  const std::size_t n =
      ZSTD_decompress(millimetres.data(), millimetres.size_bytes(), zstd.data(), zstd.size());
  if (ZSTD_isError(n)) return std::string("Zstandard: ") + ZSTD_getErrorName(n);
  if (n != millimetres.size_bytes())
    return "frame holds " + std::to_string(n) + " bytes, not the " +
           std::to_string(millimetres.size_bytes()) + " of the depth camera's image";
  if constexpr (!kLittleEndian)
    for (std::uint16_t& v : millimetres) v = static_cast<std::uint16_t>(v << 8 | v >> 8);
  return "";
}

void write_png_bgr8(const std::string& path, const std::uint8_t* pixels, int width, int height,
                    std::size_t stride) {
  std::vector<png_bytep> rows(static_cast<std::size_t>(std::max(height, 0)));
  for (int v = 0; v < height; ++v)
    rows[static_cast<std::size_t>(v)] = const_cast<png_bytep>(pixels + static_cast<std::size_t>(v) * stride);
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (file == nullptr) throw InputError(path, "", "cannot create file");
  const std::string error =
      write_png(rows.data(), width, height, 8, PNG_COLOR_TYPE_RGB, true, nullptr, file);
  const bool closed = std::fclose(file) == 0;
  if (!error.empty() || !closed) throw InputError(path, "", "cannot write PNG" + (error.empty() ? "" : ": " + error));
}

}  // namespace fdv
