#pragma once
/// The project's own dataset folder (docs/FORMATS.md, "fdv dataset"):
///
///   DIR/dataset.yaml        manifest: format version, event sensor size, optional truth info
///   DIR/calibration.yaml    the rig calibration (fdv/core/calibration.h layout)
///   DIR/events.bin          "FDVEVT01", u32 width, u32 height, u64 count, then count 16-byte
///                           little-endian records {i64 t_ns, u16 x, u16 y, u8 polarity, 3 pad}
///   DIR/imu.csv             t_ns,gx,gy,gz,ax,ay,az            (rad/s, m/s^2, IMU frame)
///   DIR/odometry.csv        t_ns,px,py,pz,qx,qy,qz,qw,vx,vy,vz,wx,wy,wz   (T_W_B, v in W, w in B)
///   DIR/depth.csv           t_ns,file                         (depth/*.zst or *.png: depth_image.h)
///   DIR/truth/objects.csv   t_ns,id,px,py,pz,vx,vy,vz         (optional ground truth, W frame)
///   DIR/truth/body.csv      same columns as odometry.csv      (optional true vehicle motion)
///
/// Every stream file is optional except events.bin.
/// Thread safety: the reader is not thread-safe (one per thread, as every RecordingReader).
#include <cstdint>
#include <istream>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "fdv/core/camera.h"
#include "fdv/io/recording.h"

namespace fdv {

inline constexpr const char* kDatasetManifest = "dataset.yaml";
inline constexpr char kEventsMagic[8] = {'F', 'D', 'V', 'E', 'V', 'T', '0', '1'};
inline constexpr std::size_t kEventsHeaderBytes = 24;

/// Bounds on what a dataset folder declares (docs/FORMATS.md, "Bad input").
/// Largest sensor side in dataset.yaml: today's largest event sensors are 1280x960; the pipeline
/// allocates per-pixel images of width x height.
inline constexpr int kMaxDatasetSensorSide = kMaxCameraSide;
/// Pixels of one depth frame, checked in the PNG header before decoding: 4x the 1280x720 of
/// common depth cameras; 16 MiB as floats.
inline constexpr std::int64_t kMaxDepthPixels = std::int64_t{2048} * 2048;
/// A depth file is read whole before decoding: 2048x2048 16-bit stored uncompressed is 8 MiB.
inline constexpr std::uint64_t kMaxDepthFileBytes = 16 << 20;
/// Depth frames per chunk at most (each up to 16 MiB), whatever the chunk's time horizon.
inline constexpr std::size_t kMaxDepthFramesPerChunk = 8;

std::unique_ptr<RecordingReader> open_dataset(const std::string& dir, const ReaderOptions& options);

/// Reads the true vehicle motion `truth/body.csv` of a dataset (empty if absent).
std::vector<OdometrySample> read_body_truth(const std::string& dir);
/// Reads `truth/objects.csv` of a dataset (empty if absent).
std::vector<ObjectState> read_object_truth(const std::string& dir);

// One file of the folder from memory or any stream, in full, by the same code open_dataset()
// runs on the files (for fuzzing and tests). `name` stands for the file in report positions
// ("name:line N", "byte N") and errors. Recoverable damage is dropped and counted in `report`;
// the rest throws InputError (name, position, reason). Nothing else escapes.

struct DatasetManifest {
  int width = 0;  ///< event sensor [px], 1..kMaxDatasetSensorSide
  int height = 0;
};
/// dataset.yaml's text (at most kMaxConfigFileBytes, fdv/core/config_text.h).
DatasetManifest parse_dataset_manifest(std::string_view yaml_text, const std::string& name);

/// events.bin; `in` must be seekable (its size bounds the count). The header must give
/// width x height (the manifest's). Events outside the sensor or going back are dropped.
std::vector<Event> read_dataset_events(std::unique_ptr<std::istream> in, const std::string& name,
                                       int width, int height, ReadReport& report);

std::vector<ImuSample> read_dataset_imu(std::unique_ptr<std::istream> in, const std::string& name,
                                        ReadReport& report);
/// odometry.csv or truth/body.csv.
std::vector<OdometrySample> read_dataset_poses(std::unique_ptr<std::istream> in,
                                               const std::string& name, ReadReport& report);
/// truth/objects.csv.
std::vector<ObjectState> read_dataset_objects(std::unique_ptr<std::istream> in,
                                              const std::string& name, ReadReport& report);

/// A depth.csv row: the PNG `file` (relative to the folder) holds the frame at `t`.
struct DepthIndexRow {
  TimeNs t = 0;
  std::string file;
};
std::vector<DepthIndexRow> read_dataset_depth_index(std::unique_ptr<std::istream> in,
                                                    const std::string& name, ReadReport& report);
/// One depth file's bytes, either encoding (depth_image.h). A frame that is neither, is not
/// 16-bit greyscale, has more than kMaxDepthPixels, or differs from `camera`'s size (when given;
/// a Zstandard frame needs it) is dropped and counted (nullopt).
std::optional<DepthFrame> decode_dataset_depth(std::span<const std::uint8_t> png, TimeNs t,
                                               const std::optional<PinholeCamera>& camera,
                                               const std::string& name, ReadReport& report);

}  // namespace fdv
