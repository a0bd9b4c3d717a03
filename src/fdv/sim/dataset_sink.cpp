#include "fdv/sim/dataset_sink.h"

#include <filesystem>

namespace fdv::sim {

DatasetSink::DatasetSink(const std::string& dir, const Calibration& calib, DepthEncoding depth_encoding)
    : writer_(dir, calib, depth_encoding), labels_((std::filesystem::path(dir) / kLabelsFile).string()) {}

void DatasetSink::on_events(std::span<const Event> events, std::span<const std::int16_t> labels) {
  writer_.add_events(events);
  labels_.append(labels);
}

void DatasetSink::finish(const std::string& manifest_extra) {
  labels_.finish();
  writer_.finish(manifest_extra);
}

}  // namespace fdv::sim
