#pragma once
/// The project's own dataset folder (docs/FORMATS.md, "fdv dataset"):
///
///   DIR/dataset.yaml        manifest: format version, event sensor size, optional truth info
///   DIR/calibration.yaml    the rig calibration (fdv/core/calibration.h layout)
///   DIR/events.bin          "FDVEVT01", u32 width, u32 height, u64 count, then count 16-byte
///                           little-endian records {i64 t_ns, u16 x, u16 y, u8 polarity, 3 pad}
///   DIR/imu.csv             t_ns,gx,gy,gz,ax,ay,az            (rad/s, m/s^2, IMU frame)
///   DIR/odometry.csv        t_ns,px,py,pz,qx,qy,qz,qw,vx,vy,vz,wx,wy,wz   (T_W_B, v in W, w in B)
///   DIR/depth.csv           t_ns,file                         (16-bit PNG, millimetres, 0 invalid)
///   DIR/truth/objects.csv   t_ns,id,px,py,pz,vx,vy,vz         (optional ground truth, W frame)
///   DIR/truth/body.csv      same columns as odometry.csv      (optional true vehicle motion)
///
/// Every stream file is optional except events.bin.
#include <memory>
#include <string>

#include "fdv/io/recording.h"

namespace fdv {

inline constexpr const char* kDatasetManifest = "dataset.yaml";
inline constexpr char kEventsMagic[8] = {'F', 'D', 'V', 'E', 'V', 'T', '0', '1'};
inline constexpr std::size_t kEventsHeaderBytes = 24;

std::unique_ptr<RecordingReader> open_dataset(const std::string& dir, const ReaderOptions& options);

/// Reads the true vehicle motion `truth/body.csv` of a dataset (empty if absent).
std::vector<OdometrySample> read_body_truth(const std::string& dir);
/// Reads `truth/objects.csv` of a dataset (empty if absent).
std::vector<ObjectState> read_object_truth(const std::string& dir);

}  // namespace fdv
