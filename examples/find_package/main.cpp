// Streams synthetic events through fdv::Perception from the installed package and checks what
// it counted: every event in, one window per 25 ms, one callback per window.
#include <iostream>
#include <vector>

#include "fdv/pipeline/perception.h"

int main() {
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
            << window_callbacks << "\n";
  const bool ok = c.events == events.size() && c.windows == 4 && window_callbacks == 4;
  return ok ? 0 : 1;
}
