#include "fdv/pipeline/detector_input.h"

namespace fdv {

CompensatedEventsView detector_input(const CompensatedWindow& window, int threads) {
  const CompensationReport& r = window.report;
  CompensatedEventsView view;
  view.t_start = window.t_start;
  view.t_end = window.t_end;
  view.width = window.width;
  view.height = window.height;
  view.pixel = window.pixel();
  view.t_s = window.t_s();
  view.time_sorted = r.events_out_of_order == 0;  // lets the detector binary-search time slices
  view.omega_rad_s = r.has_omega ? r.omega_E.norm() : 0.0;
  view.speed_m_s = r.has_velocity ? r.v_E.norm() : 0.0;
  view.threads = threads;
  return view;
}

CompensatedEventsView detector_input(const CompensatedWindow& window, const Compensator& compensator,
                                     int threads) {
  CompensatedEventsView view = detector_input(window, threads);
  // One pointer captured: std::function keeps it inline (no allocation per window).
  const Compensator* c = &compensator;
  view.observed_at = [c](const Eigen::Vector2d& px, double t_s) { return c->observed_position(px, t_s); };
  return view;
}

}  // namespace fdv
