// Format detection: magic bytes for files, layout for folders.
#include <filesystem>
#include <fstream>

#include "fdv/core/error.h"
#include "fdv/io/dataset/dataset_reader.h"
#include "fdv/io/recording.h"
#include "fdv/io/aedat4/aedat4_reader.h"
#include "fdv/io/hdf5/hdf5_reader.h"
#include "fdv/io/prophesee/prophesee_raw_reader.h"
#include "fdv/io/rpg/rpg_text_reader.h"
#include "fdv/io/rosbag/rosbag_reader.h"

namespace fdv {
namespace fs = std::filesystem;

std::unique_ptr<RecordingReader> open_recording(const std::string& path,
                                                const ReaderOptions& options) {
  if (!fs::exists(path)) throw InputError(path, "", "no such file or folder");
  if (fs::is_directory(path)) {
    if (fs::exists(fs::path(path) / kDatasetManifest)) return open_dataset(path, options);
    if (fs::exists(fs::path(path) / kRpgEventsFile)) return open_rpg_text(path, options);
    if (is_ros2_bag_folder(path)) return open_ros2_bag(path, options);
    throw InputError(path, "", "folder is not a recognised dataset (no " +
                                   std::string(kDatasetManifest) + ")");
  }
  // Opening a FIFO blocks until a writer comes, and a device never ends.
  if (!fs::is_regular_file(path))
    throw InputError(path, "", "not a regular file (a FIFO or a device cannot be read as a recording)");
  std::ifstream in(path, std::ios::binary);
  std::string head(256, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(in.gcount()));
  if (head.starts_with("#!AER-DAT4.0")) return open_aedat4(path, options);
  // "% " text header: Prophesee RAW; the reader parses the whole header and rejects encodings
  // other than EVT 2.0 / 3.0 (and DAT files, whose header also starts with "% ") with a reason.
  if (looks_like_prophesee_raw(head)) return open_prophesee_raw(path, options);
  // ROS 1 bag ("#ROSBAG V2.0"; older versions are rejected by the reader with a reason); ROS 2
  // bag file (an SQLite database: the reader checks for the topics/messages tables).
  if (head.starts_with("#ROSBAG V")) return open_ros1_bag(path, options);
  if (head.starts_with(kSqliteMagic)) return open_ros2_bag(path, options);
  if (looks_like_hdf5(head)) return open_hdf5(path, options);
  if (head.starts_with("\x89MCAP"))
    throw InputError(path, "byte 0",
                     "MCAP (ROS 2) is not supported: Debian ships no MCAP library; "
                     "`ros2 bag convert` can rewrite the bag with sqlite3 storage");
  throw InputError(path, "byte 0", "unrecognised file format");
}

}  // namespace fdv
