#pragma once
/// A dataset's depth frame files, in either of their two encodings (docs/FORMATS.md, "fdv
/// dataset"): z-depth in millimetres as 16-bit unsigned integers, 0 = invalid, row-major.
///  - PNG: 16-bit greyscale, any PNG writer's output (libpng).
///  - Zstandard: the frame's pixels as little-endian uint16 in one Zstandard frame, nothing
///    else; the size is the depth camera's (calibration.yaml). Inflate is most of a PNG's
///    decoding time, and Zstandard decodes several times faster at a similar size.
/// Also 8-bit colour PNGs, for `fdv run --visualize`'s panels.
/// Thread safety: free functions without shared state.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace fdv {

enum class DepthEncoding { kPng, kZstd };

/// What a depth file's first bytes say it is: kPng or kZstd, or false when neither.
bool sniff_depth_encoding(std::span<const std::uint8_t> bytes, DepthEncoding& encoding);

/// Metres to the files' millimetres: rounded, 0 for invalid (not finite or ≤ 0), 65535 at most.
/// `millimetres` has the size of `metres`.
void metres_to_millimetres(std::span<const float> metres, std::span<std::uint16_t> millimetres);

/// The files' millimetres to metres, as the reader gives them (0 stays 0: invalid).
void millimetres_to_metres(std::span<const std::uint16_t> millimetres, std::span<float> metres);

/// Millimetres of a width × height frame, row-major.
std::vector<std::uint8_t> encode_depth_png(std::span<const std::uint16_t> millimetres, int width,
                                           int height);
std::vector<std::uint8_t> encode_depth_zstd(std::span<const std::uint16_t> millimetres);

/// Decodes into `millimetres` (width × height values, the size the caller expects). Returns ""
/// on success, otherwise the reason the bytes are not such a frame; `millimetres` is then
/// unspecified. Never reads or writes outside the two spans.
std::string decode_depth_png(std::span<const std::uint8_t> png, int width, int height,
                             std::span<std::uint16_t> millimetres);
std::string decode_depth_zstd(std::span<const std::uint8_t> zstd, std::span<std::uint16_t> millimetres);

/// An 8-bit, 3-channel image in blue-green-red order (OpenCV's), width × height, row-major with
/// `stride` bytes a row, to a PNG file. Throws InputError naming the path if it cannot be written.
void write_png_bgr8(const std::string& path, const std::uint8_t* pixels, int width, int height,
                    std::size_t stride);

}  // namespace fdv
