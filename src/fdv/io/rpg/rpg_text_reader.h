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
#include <istream>
#include <memory>
#include <string>
#include <vector>

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

/// One file of the layout read from any stream (e.g. a std::istringstream over a fuzzer's
/// buffer), in full, by the same code open_rpg_text() runs on the files. `name` stands for the
/// file in report positions ("name:line N") and errors. Bad lines are dropped and counted in
/// `report`; events are also checked against the 240x180 sensor and time order (EventSanitizer).
/// Throws InputError for a line longer than kMaxLineBytes (text_fields.h) or a read error.
std::vector<Event> read_rpg_events(std::unique_ptr<std::istream> in, const std::string& name,
                                   ReadReport& report);
std::vector<ImuSample> read_rpg_imu(std::unique_ptr<std::istream> in, const std::string& name,
                                    ReadReport& report);
std::vector<OdometrySample> read_rpg_groundtruth(std::unique_ptr<std::istream> in,
                                                 const std::string& name, ReadReport& report);
/// calib.txt; throws InputError (name, line, reason) when it is malformed.
Calibration read_rpg_calib(std::unique_ptr<std::istream> in, const std::string& name);

}  // namespace fdv
