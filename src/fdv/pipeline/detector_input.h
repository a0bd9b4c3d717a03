#pragma once
/// The one adapter from the compensation's output to the detector's input: a CompensatedWindow
/// seen as a CompensatedEventsView (detection knows nothing of compensation, so it lives here).
///
///   const CompensatedWindow& cw = compensator->compensate(in);
///   DetectionResult r = detector.detect(detector_input(cw, *compensator, threads), priors);
///
/// The view borrows the window's arrays (and the compensator): valid until the compensator's next
/// call. The same window always gives the same view, so that the pipeline, the tests and the
/// benchmarks feed the detector alike.
#include "fdv/compensation/compensator.h"
#include "fdv/detection/time_images.h"

namespace fdv {

/// The window's events on the undistorted grid; ‖ω‖ and ‖v‖ for the threshold θ (paper §IV-B.1;
/// 0 when the compensation had none); time_sorted when the compensation kept the events in time
/// order; `threads` for the detector's per-event stages. No inverse warp: the detector reports
/// its centre on the compensated grid (the camera at t_start).
CompensatedEventsView detector_input(const CompensatedWindow& window, int threads = 1);

/// As above, and the detector reports its centre where the camera saw it at the detection's time,
/// through the compensator's inverse warp (Compensator::observed_position): what Perception does.
CompensatedEventsView detector_input(const CompensatedWindow& window, const Compensator& compensator,
                                     int threads = 1);

}  // namespace fdv
