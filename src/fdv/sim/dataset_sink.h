#pragma once
/// A SimulationSink that writes the project's dataset folder (fdv::DatasetWriter) plus the
/// per-event labels (truth/event_labels.bin).
///
///   Simulator sim(config);
///   DatasetSink sink(out_dir, sim.calibration());
///   auto summary = sim.run(sink);
///   sink.finish(sim.manifest_yaml());
/// Thread safety: not thread-safe; the Simulator calls it from one thread.
#include <string>

#include "fdv/io/dataset/dataset_writer.h"
#include "fdv/sim/event_labels.h"
#include "fdv/sim/simulator.h"

namespace fdv::sim {

class DatasetSink : public SimulationSink {
 public:
  /// Creates `dir` (and depth/, truth/) and writes calibration.yaml. Throws InputError.
  DatasetSink(const std::string& dir, const Calibration& calib,
              DepthEncoding depth_encoding = DepthEncoding::kZstd);
  void on_events(std::span<const Event> events, std::span<const std::int16_t> labels) override;
  void on_imu(const ImuSample& s) override { writer_.add_imu(s); }
  void on_depth(const DepthFrame& f) override { writer_.add_depth(f); }
  void on_odometry(const OdometrySample& s) override { writer_.add_odometry(s); }
  void on_body_truth(const OdometrySample& s) override { writer_.add_body_truth(s); }
  void on_unflown_body_truth(const OdometrySample& s) override { writer_.add_unflown_body_truth(s); }
  void on_object_truth(const ObjectState& s) override { writer_.add_object_truth(s); }
  /// Completes the files; `manifest_extra` goes into dataset.yaml (Simulator::manifest_yaml()).
  void finish(const std::string& manifest_extra);

 private:
  DatasetWriter writer_;
  EventLabelWriter labels_;
};

}  // namespace fdv::sim
