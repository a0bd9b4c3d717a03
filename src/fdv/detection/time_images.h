#pragma once
/// The count, mean-time and normalised mean-time images of a compensated window (paper §III,
/// eqs. 1-4), on the undistorted pixel grid.
///
///   TimeImages ti;                      // reuse across windows: buffers are kept
///   build_time_images(view, ti);
///   ti.count (CV_32S) = I, ti.mean_time_s (CV_32F) = T, ti.normalized (CV_32F) = N
///
///   I_ij = |ξ_ij|                       number of compensated events on pixel (i, j)
///   T_ij = (1/I_ij)·Σ_{ξ_ij} (t − t0)    mean time [s] relative to the window start
///   N_ij = (T_ij − min T) / (max T − min T)
/// min and max are taken over pixels with I > 0 (T is undefined elsewhere); pixels with I = 0 are 0
/// in T and N. When max T = min T (e.g. a single event) N is 0 everywhere: no temporal structure.
///
/// Arithmetic (float, so that results do not depend on the implementation): Σ(t − t0) is summed
/// per pixel in event order; T = Σ / I; N = (T − min T)·s with s = float(1 / (max T − min T));
/// mean_normalized is computed in double. reference_time_images.h is the plain version the
/// optimised builder is tested against.
///
/// Pitfall: the images are reused, and each call rewrites only the 16-pixel blocks that held events
/// in this window or the previous one (the rest are already 0), found through per-group marks: the
/// work is proportional to the events, not to the frame. Treat the images as read-only (clone()
/// before modifying). Assigning a different cv::Mat to a member is detected (full rebuild).
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <functional>
#include <opencv2/core.hpp>
#include <span>
#include <vector>

#include "fdv/core/time.h"

namespace fdv {

/// What detection needs of a motion-compensated window (compensation/compensator.h produces
/// the arrays; the pipeline joins the two modules). Borrowed, valid for the call.
struct CompensatedEventsView {
  TimeNs t_start = 0;
  TimeNs t_end = 0;
  int width = 0;  ///< undistorted grid size
  int height = 0;
  std::span<const std::int32_t> pixel;  ///< row-major index v·width + u of each event, in range
  std::span<const float> t_s;           ///< event time − t_start [s]
  double omega_rad_s = 0;  ///< ‖ω‖ of the camera over the window, 0 when unknown (threshold θ)
  double speed_m_s = 0;    ///< ‖v‖ of the camera, 0 when unknown (threshold θ)
  /// t_s is non-decreasing (the compensators keep the input's time order and report it): lets the
  /// detector binary-search time slices. False is always safe.
  bool time_sorted = false;
  /// False: the window's events were already summed by the sources that sum evidence over
  /// consecutive windows (the evidence source), which skip it: an overlapping window between two
  /// that do not overlap (PerceptionOptions' windows.step_ms).
  bool new_evidence = true;
  /// Threads (run_parts in fdv/core/thread_pool.h, at most 8) for build_time_images (pixel
  /// ranges), the segmentation and the pre-processing (bands of rows). Results are identical for
  /// any count.
  int threads = 1;
  /// Maps a point of this grid (the camera at t_start) to where the camera saw it t_s [s] later, on
  /// the same undistorted grid: the inverse of the compensation's warp
  /// (Compensator::observed_position). Empty = identity (no ego-motion). The detector reports its
  /// center_raw / center_normalized / box_raw through it: the camera at the detection's time.
  std::function<Eigen::Vector2d(const Eigen::Vector2d& px, double t_s)> observed_at = {};
  /// Every event's time of the window when `pixel` and `t_s` hold only a part of it (the tracks'
  /// surroundings: PerceptionOptions::gates_only_between_anchors), in the same order as the whole
  /// window's; empty when they hold the whole window. The sources measure an object against the
  /// window's background (its events per pixel, the events of a time slice, their mean time) from it.
  std::span<const float> window_t_s = {};
};

struct TimeImages {
  cv::Mat count;        ///< I, CV_32S
  cv::Mat sum_time_s;   ///< Σ (t − t0) per pixel [s], CV_32F
  cv::Mat mean_time_s;  ///< T [s], CV_32F, 0 where I = 0
  cv::Mat normalized;   ///< N in [0, 1], CV_32F, 0 where I = 0
  int events = 0;
  int pixels_with_events = 0;
  float t_min_s = 0, t_max_s = 0;  ///< min / max of T over pixels with events
  double mean_normalized = 0;      ///< mean of N over pixels with events (threshold θ, §IV-B.1)
  /// The rows that can hold this window's events: those of the 256-pixel groups it has events in
  /// (a superset of the rows with I > 0; empty when there are none). A window of the events near a
  /// few gates spans a band of rows, and the passes after these images need visit only that band.
  cv::Range event_rows = cv::Range(0, 0);
  /// 16-pixel blocks that pass 1 looked at: those of the groups (16 blocks, 256 pixels) that held
  /// events in this window or the previous one. The work bound that a sparse window's cost follows.
  std::size_t blocks_visited = 0;

  // Scratch, kept between windows (no allocation once warmed up).
  cv::Mat accumulator;  ///< interleaved (count, Σt) per pixel, CV_32FC2; all 0 between calls
  /// Per 16-pixel block: bit 0 = events in this window, bit 1 = events in the previous window.
  std::vector<std::uint8_t> blocks;
  /// Per group of 16 blocks: 1 where `blocks` may be nonzero (events now, or in the previous
  /// window). The passes skip the other groups, so a sparse window costs its events, not the frame.
  std::vector<std::uint8_t> groups_now, groups_before;
  std::vector<double> chunk_sums;  ///< Σ T per fixed chunk of blocks (summation order fixed)
  struct PixelTime {
    std::int32_t pixel;
    float t_s;
  };
  std::vector<PixelTime>
      sorted;  ///< with several threads: the events grouped by the thread that adds them
  std::array<const void*, 5> buffer_keys{};  ///< data pointers of the images when last built
};

/// Fills `out` (reusing its buffers). Events whose pixel index is out of range are ignored.
void build_time_images(const CompensatedEventsView& view, TimeImages& out);

/// Allocates and blanks `out`'s images for a width × height grid, touching every page, unless they
/// already are: build_time_images does it on a new size, and a caller that knows the size ahead
/// (Detector's constructor) calls it so that the first window does not pay for it.
void prepare_time_images(TimeImages& out, int width, int height);

}  // namespace fdv
