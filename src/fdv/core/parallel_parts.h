#pragma once
/// Splitting one loop into a few parts run on OpenCV's thread pool (cv::parallel_for_, TBB here),
/// for the per-event stages of the front end (compensation, time images).
///
///   struct Work { void operator()(int part) const { ... } } work;
///   run_parts(2, work);            // part 0 and part 1, possibly on two threads
///
/// The calling thread takes part too. Sequential when parts ≤ 1 or when OpenCV runs
/// single-threaded (cv::setNumThreads(1)). What the parts compute must not depend on which thread
/// ran which part (each writes its own output range). No allocation by this code (OpenCV's pool
/// may allocate internally). The body must not throw.
#include <opencv2/core.hpp>

namespace fdv {

/// The most parts the per-pixel stages (time images, segmentation, pre-processing) split a window
/// into, whatever thread count is asked for (their per-part state lives in fixed arrays).
inline constexpr int kMaxImageParts = 8;

template <class Body>
void run_parts(int parts, const Body& body) {
  if (parts <= 1) {
    body(0);
    return;
  }
  struct Loop final : cv::ParallelLoopBody {
    const Body* body;
    explicit Loop(const Body* b) : body(b) {}
    void operator()(const cv::Range& r) const override {
      for (int i = r.start; i < r.end; ++i) (*body)(i);
    }
  };
  cv::parallel_for_(cv::Range(0, parts), Loop(&body), parts);
}

}  // namespace fdv
