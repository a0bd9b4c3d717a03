// Streams synthetic events through fdv::Perception from the installed package and checks what
// it counted: every event in, one window per 25 ms, one callback per window. It registers a
// candidate source of its own first, as a user's detector plug-in would be (the detector makes it).
#include <iostream>
#include <memory>
#include <optional>
#include <vector>

#include "fdv/detection/candidate_source.h"
#include "fdv/pipeline/perception.h"

namespace {

int sources_made = 0;

/// Finds nothing: the registration is what is tried here.
class NothingSource final : public fdv::CandidateSource {
 public:
  explicit NothingSource(const fdv::DetectorOptions&) { ++sources_made; }
  void allocate(int, int) override {}
  std::optional<fdv::Candidate> find(fdv::SourceWindow&, fdv::DetectionResult&) override { return std::nullopt; }
};

}  // namespace

int main() {
  fdv::register_candidate_source("nothing", fdv::make_source<NothingSource>);

  fdv::Calibration calibration;
  calibration.event_camera = {.width = 64, .height = 48, .fx = 60, .fy = 60, .cx = 32, .cy = 24};

  fdv::PerceptionOptions options;
  options.compensation.method = fdv::CompensationMethod::kNone;  // no IMU in this stream
  options.estimate_trajectories = false;  // nor odometry

  std::size_t window_callbacks = 0;
  fdv::Perception perception(calibration, options,
                             {.on_window = [&](const fdv::WindowResult&) { ++window_callbacks; }});

  // A 4x4 blob drifting right, 1000 events over [0, 100) ms: four 25 ms windows.
  std::vector<fdv::Event> events;
  for (int i = 0; i < 1000; ++i) {
    const fdv::TimeNs t = i * 100 * fdv::kNsPerUs;
    events.push_back({.t = t,
                      .x = static_cast<std::uint16_t>(10 + i / 25 + i % 4),
                      .y = static_cast<std::uint16_t>(20 + (i / 4) % 4),
                      .polarity = i % 2 == 0});
  }
  perception.push_events(events);
  perception.finish();

  const fdv::PerceptionCounters& c = perception.counters();
  std::cout << "events " << c.events << ", windows " << c.windows << ", window callbacks "
            << window_callbacks << ", own sources made " << sources_made << "\n";
  const bool ok = c.events == events.size() && c.windows == 4 && window_callbacks == 4 && sources_made == 1;
  return ok ? 0 : 1;
}
