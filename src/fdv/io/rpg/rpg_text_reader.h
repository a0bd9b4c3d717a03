#pragma once
/// The text layout of the RPG Event-Camera Dataset (Mueggler et al., "The Event-Camera Dataset
/// and Simulator", IJRR 2017; docs/FORMATS.md, "RPG Event Camera Dataset (text)"): a folder with
///
///   events.txt       t x y p                       (t in seconds, p 1 = ON, 0 = OFF)   required
///   imu.txt          t ax ay az gx gy gz           (m/s^2, rad/s)                       optional
///   groundtruth.txt  t px py pz qx qy qz qw        (motion-capture pose of the camera) optional
///   calib.txt        fx fy cx cy k1 k2 p1 p2 k3    (one line)                           optional
///
///   auto reader = fdv::open_rpg_text("shapes_6dof/");   // or fdv::open_recording(...)
///
/// Timestamps are converted to integer nanoseconds exactly (never through a double). The ground
/// truth pose is handed out as the odometry stream (T_W_B with B = the event camera; velocity
/// and angular velocity are not given and are zero), being the best vehicle motion available.
/// The layout does not state the sensor size: every sequence of the dataset was recorded with
/// (or simulated for) a DAVIS240C, so the reader uses 240x180 and drops and counts events
/// outside it. Bad lines are dropped and counted with their file and line. Not thread-safe.
#include <memory>
#include <string>

#include "fdv/io/recording.h"

namespace fdv {

inline constexpr const char* kRpgEventsFile = "events.txt";
/// DAVIS240C, the camera of every sequence of the dataset (dataset paper, Section 3).
inline constexpr int kRpgWidth = 240;
inline constexpr int kRpgHeight = 180;

/// Opens the folder `dir`. Throws InputError when events.txt cannot be opened or calib.txt is
/// malformed (file, line and reason).
std::unique_ptr<RecordingReader> open_rpg_text(const std::string& dir,
                                               const ReaderOptions& options = {});

}  // namespace fdv
