#pragma once
/// The one thread pool: a small fixed set of worker threads for the simulator's parallel loops and
/// the per-event stages of the front end (compensation, time images, segmentation).
///
///   ThreadPool pool(2);                                   // 0 = all cores
///   pool.parallel_for(tiles.size(), [&](std::size_t i) { process(tiles[i]); });
///   run_parts(2, [&](int part) { ... });                  // on ThreadPool::shared()
///
/// Indices are handed out one at a time in increasing order (dynamic scheduling), so put the
/// expensive items first. Idle workers sleep on a condition variable (no spinning: the machine
/// is shared with compilers and other simulations). The caller's thread works too. What a
/// parallel loop computes must not depend on which thread ran which index. An exception thrown
/// by `fn` is rethrown by parallel_for after the loop. A call made while the pool is busy (from
/// another thread, or from inside one of its loops) runs its loop on the calling thread alone.
#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace fdv {

class ThreadPool {
 public:
  explicit ThreadPool(int threads) {
    const int n =
        threads > 0 ? threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    for (int i = 1; i < n; ++i) workers_.emplace_back([this] { work(); });
  }
  ~ThreadPool() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    for (auto& t : workers_) t.join();
  }
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  /// The process-wide pool of run_parts, one thread per core, started on first use.
  static ThreadPool& shared() {
    static ThreadPool pool(0);
    return pool;
  }

  int size() const { return static_cast<int>(workers_.size()) + 1; }

  void parallel_for(std::size_t n, const std::function<void(std::size_t)>& fn) {
    if (workers_.empty() || n <= 1 || running_.exchange(true)) {
      for (std::size_t i = 0; i < n; ++i) fn(i);
      return;
    }
    struct Release {
      std::atomic<bool>& running;
      ~Release() { running.store(false); }
    } release{running_};
    {
      std::lock_guard<std::mutex> lock(mutex_);
      fn_ = &fn;
      n_ = n;
      next_.store(0);
      busy_ = workers_.size();
      error_ = nullptr;
      ++generation_;
    }
    wake_.notify_all();
    run_items();
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [this] { return busy_ == 0; });
    fn_ = nullptr;
    if (error_) std::rethrow_exception(error_);
  }

 private:
  void run_items() {
    for (std::size_t i; (i = next_.fetch_add(1)) < n_;) {
      try {
        (*fn_)(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex_);
        if (!error_) error_ = std::current_exception();
      }
    }
  }
  void work() {
    std::uint64_t seen = 0;
    for (;;) {
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
        if (stop_) return;
        seen = generation_;
      }
      run_items();
      std::lock_guard<std::mutex> lock(mutex_);
      if (--busy_ == 0) done_.notify_one();
    }
  }

  std::vector<std::thread> workers_;
  std::atomic<bool> running_{false};  ///< a parallel_for is using the workers
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  const std::function<void(std::size_t)>* fn_ = nullptr;
  std::size_t n_ = 0;
  std::atomic<std::size_t> next_{0};
  std::size_t busy_ = 0;
  std::uint64_t generation_ = 0;
  bool stop_ = false;
  std::exception_ptr error_;
};

/// The most parts the per-pixel stages (time images, segmentation, pre-processing) split a window
/// into, whatever thread count is asked for (their per-part state lives in fixed arrays).
inline constexpr int kMaxImageParts = 8;

/// body(0) ... body(parts - 1) on ThreadPool::shared(), for one loop split into a few parts that
/// each write their own output range. Sequential when parts ≤ 1: no thread is started then.
template <class Body>
void run_parts(int parts, const Body& body) {
  if (parts <= 1) {
    body(0);
    return;
  }
  ThreadPool::shared().parallel_for(static_cast<std::size_t>(parts),
                                    [&body](std::size_t i) { body(static_cast<int>(i)); });
}

}  // namespace fdv
