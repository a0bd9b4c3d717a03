// Format detection: magic bytes for files, layout for folders.
#include <filesystem>
#include <fstream>

#include "fdv/core/error.h"
#include "fdv/io/dataset/dataset_reader.h"
#include "fdv/io/recording.h"
// [format include slot: aedat4]
// [format include slot: prophesee]
// [format include slot: rpg]
// [format include slot: rosbag]

namespace fdv {
namespace fs = std::filesystem;

std::unique_ptr<RecordingReader> open_recording(const std::string& path,
                                                const ReaderOptions& options) {
  if (!fs::exists(path)) throw InputError(path, "", "no such file or folder");
  if (fs::is_directory(path)) {
    if (fs::exists(fs::path(path) / kDatasetManifest)) return open_dataset(path, options);
    // [folder format slot: rpg]
    throw InputError(path, "", "folder is not a recognised dataset (no " +
                                   std::string(kDatasetManifest) + ")");
  }
  std::ifstream in(path, std::ios::binary);
  std::string head(256, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(in.gcount()));
  // [file format slot: aedat4]
  // [file format slot: prophesee]
  // [file format slot: rosbag]
  throw InputError(path, "byte 0", "unrecognised file format");
}

}  // namespace fdv
