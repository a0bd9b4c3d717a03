// A candidate source registered from outside the detector, as a user's program would register its
// own: the detector tries it after the built-in ones, its diagnostics come back under its name, and
// its time is a column of timing.csv. No detector code knows it.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <optional>
#include <string>

#include "detection/synthetic_scene.h"
#include "fdv/compensation/compensator.h"
#include "fdv/core/error.h"
#include "fdv/detection/candidate_source.h"
#include "fdv/detection/detector.h"
#include "fdv/pipeline/detector_input.h"
#include "fdv/results/reader.h"
#include "fdv/results/writer.h"
#include "test_support.h"

namespace fdv {
namespace {

struct ToyDiagnostics {
  int events = 0;  ///< compensated events of the window it saw
  bool first_object = false;
};

/// Finds nothing; reports what it saw.
class ToySource final : public CandidateSource {
 public:
  static constexpr std::string_view kName = "toy";
  explicit ToySource(const DetectorOptions&) {}
  void allocate(int, int) override {}
  std::optional<Candidate> find(SourceWindow& in, DetectionResult& res) override {
    ToyDiagnostics& d = res.diagnostics_of(kName).write<ToyDiagnostics>();
    d.events = in.ti.events;
    d.first_object = in.first_object;
    return std::nullopt;
  }
};

/// The toy source registered for one test.
struct ToyRegistration {
  ToyRegistration() { register_candidate_source(ToySource::kName, make_source<ToySource>); }
  ~ToyRegistration() { unregister_candidate_source(ToySource::kName); }
};

TEST(CandidateSourceRegistry, ARegisteredSourceIsTriedAndReportsUnderItsName) {
  const ToyRegistration toy;
  Calibration calibration;
  calibration.event_camera.width = 640;
  calibration.event_camera.height = 480;
  calibration.event_camera.fx = calibration.event_camera.fy = 400;
  calibration.event_camera.cx = 320;
  calibration.event_camera.cy = 240;
  test::BlobScene scene;  // background noise only: no built-in source finds anything
  scene.blob_rate_ev_s = 0;
  scene.edge_segments = 0;
  const std::vector<Event> events = test::make_scene(calibration.event_camera, scene);
  CompensationOptions compensation;
  compensation.method = CompensationMethod::kNone;
  const auto compensator = make_compensator(calibration, compensation);
  const CompensatedWindow& window =
      compensator->compensate({.events = events, .t_start = scene.t0, .t_end = scene.t0 + scene.duration});
  DetectorOptions options;
  options.dense_motion.enabled = false;  // switched off: not made, not tried, no column value
  Detector detector(options, calibration.event_camera);
  const DetectionResult r = detector.detect(detector_input(window));

  ASSERT_TRUE(r.detections.empty()) << to_string(r.status);
  const ToyDiagnostics* seen = r.diagnostics<ToyDiagnostics>("toy");
  ASSERT_NE(seen, nullptr);
  EXPECT_EQ(seen->events, detector.time_images().events);
  EXPECT_TRUE(seen->first_object);
  EXPECT_EQ(r.diagnostics<ToyDiagnostics>("gaussian_fit"), nullptr);  // another source's, of another type
  ASSERT_FALSE(r.timings.sources().empty());
  EXPECT_EQ(r.timings.sources().back().source, "toy");  // tried last
  EXPECT_EQ(r.timings.source_ms("dense_motion"), 0);

  // Its time is a stage of timing.csv and of the summary's timing_ms, between the detector's.
  const std::string dir = test::scratch_dir("results_source_plugin");
  WindowResult w;
  w.timings.detection = r.timings;
  std::map<std::string, Summary> timing_ms;
  {
    ResultsWriter out(dir);
    out.window(w);
    timing_ms = out.timing_ms();
  }
  std::ifstream in(dir + "/timing.csv");
  std::string header;
  std::getline(in, header);
  EXPECT_NE(header.find(",count_contrast,evidence,toy,refine,detection_total,"), std::string::npos) << header;
  const std::vector<WindowTimingRow> rows = read_timing(dir);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].stage_ms.at("toy"), r.timings.source_ms("toy"));
  EXPECT_EQ(rows[0].stage_ms.count("dense_motion"), 0u);
  EXPECT_EQ(timing_ms.at("toy").count, 1u);
}

TEST(CandidateSourceRegistry, NamesAreWordsRegisteredOnce) {
  EXPECT_THROW(register_candidate_source("gaussian_fit", make_source<ToySource>), ConfigError);
  EXPECT_THROW(register_candidate_source("a toy", make_source<ToySource>), ConfigError);
  EXPECT_FALSE(unregister_candidate_source("gaussian_fit"));  // the built-in sources stay
}

}  // namespace
}  // namespace fdv
