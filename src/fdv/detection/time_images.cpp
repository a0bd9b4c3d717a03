#include "fdv/detection/time_images.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cstring>
#include <limits>

#include "fdv/core/fuzz_coverage.h"
#include "fdv/core/lanes.h"
#include "fdv/core/thread_pool.h"

namespace fdv {
namespace {

// Why this shape (docs/BENCHMARKS.md has the figures): a window touches a minority of the pixels,
// and the earlier version spent most of its time in a dozen whole-image OpenCV passes. Here the
// images are cut into blocks of 16 pixels (one cache line of a float image); accumulation marks
// the blocks it touches, and the groups of 16 blocks that hold them. Only those blocks (plus the
// ones to blank from the previous window) are visited, twice: pass 1 writes I, Σt, T and finds
// min/max T; pass 2 writes N. The group marks keep a sparse window's passes off the whole frame.
// The lanes are GCC vector extensions (baseline SSE2, no FMA: the same IEEE results as the scalar
// reference).
using lanes::vd;
using lanes::vf;
using lanes::vi;

constexpr std::size_t kBlockPixels = 16;
/// Σ T is summed per chunk of this many blocks, then the chunks in order: a fixed order, so the
/// result does not depend on how the blocks are split between threads.
constexpr std::size_t kChunkBlocks = 256;
/// Blocks per group, the unit of the marks that let the passes skip unused parts of the frame.
constexpr std::size_t kGroupBlocks = 16;
constexpr std::size_t kGroupPixels = kBlockPixels * kGroupBlocks;
static_assert(kChunkBlocks % kGroupBlocks == 0);
constexpr std::uint8_t kNow = 1, kBefore = 2;
using PixelTime = TimeImages::PixelTime;

using lanes::load;
using lanes::select;
using lanes::store;

struct Images {
  float* acc;
  std::int32_t* count;
  float* sum;
  float* mean;
  float* norm;
  std::uint8_t* groups_now;  ///< TimeImages::groups_now / groups_before
  std::uint8_t* groups_before;

  /// False: every block of the group is 0, and so are its pixels in the images.
  bool group_in_use(std::size_t g) const { return (groups_now[g] | groups_before[g]) != 0; }

  /// The first group in [g, end) in use, or end. Tests eight marks at once where it can: a sparse
  /// window's scan is then a few dozen tests, even at 1280x720 (3,600 groups).
  FDV_NO_FUZZ_COVERAGE std::size_t next_group_in_use(std::size_t g, std::size_t end) const {
    while (g < end) {
      if (g % 8 == 0 && g + 8 <= end) {
        std::uint64_t now = 0, before = 0;
        std::memcpy(&now, groups_now + g, 8);
        std::memcpy(&before, groups_before + g, 8);
        if ((now | before) == 0) {
          g += 8;
          continue;
        }
      }
      if (group_in_use(g)) return g;
      ++g;
    }
    return end;
  }
};

/// Pass-1 results of a range of blocks.
struct Extremes {
  float t_min = std::numeric_limits<float>::infinity();
  float t_max = -std::numeric_limits<float>::infinity();
  int pixels = 0;
  std::size_t blocks_visited = 0;
};

/// One pixel of pass 1 (tail of an image whose size is not a multiple of 16).
FDV_NO_FUZZ_COVERAGE void pixel_pass1(const Images& im, std::size_t i, Extremes& x, double& sum_t) {
  const float c = im.acc[2 * i], s = im.acc[2 * i + 1];
  const float t = s / (c > 0 ? c : 1.0f);  // c = 0 implies s = 0: T = 0
  im.count[i] = static_cast<std::int32_t>(c);
  im.sum[i] = s;
  im.mean[i] = t;
  im.acc[2 * i] = im.acc[2 * i + 1] = 0;
  if (c > 0) {
    x.t_min = std::min(x.t_min, t);
    x.t_max = std::max(x.t_max, t);
    ++x.pixels;
    sum_t += t;
  }
}

FDV_NO_FUZZ_COVERAGE void blank_block(const Images& im, std::size_t i0, std::size_t n) {
  std::memset(im.count + i0, 0, n * sizeof(std::int32_t));
  std::memset(im.sum + i0, 0, n * sizeof(float));
  std::memset(im.mean + i0, 0, n * sizeof(float));
  std::memset(im.norm + i0, 0, n * sizeof(float));
}

/// Pass 1 over blocks [b0, b1): I, Σt, T from the accumulator (which is reset to 0 on the way),
/// min/max T, pixel count and Σ T per chunk. b0 and b1 are multiples of kChunkBlocks (or the end).
FDV_NO_FUZZ_COVERAGE Extremes pass1(const Images& im, std::uint8_t* blocks, std::size_t b0,
                                    std::size_t b1, std::size_t npx, double* chunk_sums) {
  Extremes x;
  vf lo = vf{} + x.t_min, hi = vf{} + x.t_max;
  vi pixels{};
  for (std::size_t c0 = b0; c0 < b1; c0 += kChunkBlocks) {
    const std::size_t c1 = std::min(b1, c0 + kChunkBlocks);
    vd sum_lanes[8] = {};
    double sum_tail = 0;
    const std::size_t last_group = (c1 + kGroupBlocks - 1) / kGroupBlocks;
    for (std::size_t g = im.next_group_in_use(c0 / kGroupBlocks, last_group); g < last_group;
         g = im.next_group_in_use(g + 1, last_group)) {
      const std::size_t g0 = g * kGroupBlocks, g1 = std::min(c1, g0 + kGroupBlocks);
      x.blocks_visited += g1 - g0;
      for (std::size_t b = g0; b < g1; ++b) {
        const std::uint8_t state = blocks[b];
        if (!state) continue;
        const std::size_t i0 = b * kBlockPixels, n = std::min(kBlockPixels, npx - i0);
        if (!(state & kNow)) {
          blank_block(im, i0, n);
          continue;
        }
        if (n < kBlockPixels) {
          for (std::size_t i = i0; i < i0 + n; ++i) pixel_pass1(im, i, x, sum_tail);
          continue;
        }
        for (int q = 0; q < 4; ++q) {
          const std::size_t i = i0 + 4 * static_cast<std::size_t>(q);
          const vf a = load(im.acc + 2 * i), b2 = load(im.acc + 2 * i + 4);
          const vf c = __builtin_shufflevector(a, b2, 0, 2, 4, 6);
          const vf s = __builtin_shufflevector(a, b2, 1, 3, 5, 7);
          const vi has = c > 0;
          const vf t = s / select(has, c, vf{} + 1.0f);
          store(im.count + i, __builtin_convertvector(c, vi));
          store(im.sum + i, s);
          store(im.mean + i, t);
          store(im.acc + 2 * i, vf{});
          store(im.acc + 2 * i + 4, vf{});
          lo = select(has & (t < lo), t, lo);
          hi = select(has & (t > hi), t, hi);
          pixels -= has;
          // T is 0 on pixels without events: they add nothing.
          sum_lanes[2 * q] += __builtin_convertvector(__builtin_shufflevector(t, t, 0, 1), vd);
          sum_lanes[2 * q + 1] += __builtin_convertvector(__builtin_shufflevector(t, t, 2, 3), vd);
        }
      }
    }
    double chunk = 0;
    for (const vd& l : sum_lanes) chunk += l[0] + l[1];
    chunk_sums[c0 / kChunkBlocks] = chunk + sum_tail;
  }
  for (int j = 0; j < 4; ++j) {
    x.t_min = std::min(x.t_min, lo[j]);
    x.t_max = std::max(x.t_max, hi[j]);
    x.pixels += pixels[j];
  }
  return x;
}

/// Pass 2 over blocks [b0, b1): N = (T − t_min)·scale where I > 0, else 0; block states advance
/// (this window becomes the previous one).
FDV_NO_FUZZ_COVERAGE void pass2(const Images& im, std::uint8_t* blocks, std::size_t b0,
                                std::size_t b1, std::size_t npx, float t_min, float scale) {
  const vf vmin = vf{} + t_min, vscale = vf{} + scale;
  const std::size_t last_group = (b1 + kGroupBlocks - 1) / kGroupBlocks;
  for (std::size_t g = im.next_group_in_use(b0 / kGroupBlocks, last_group); g < last_group;
       g = im.next_group_in_use(g + 1, last_group)) {
    im.groups_before[g] = im.groups_now[g];
    im.groups_now[g] = 0;
    const std::size_t g0 = g * kGroupBlocks;
    for (std::size_t b = g0; b < std::min(b1, g0 + kGroupBlocks); ++b) {
      const std::uint8_t state = blocks[b];
      blocks[b] = state & kNow ? kBefore : 0;
      if (!(state & kNow)) continue;
      const std::size_t i0 = b * kBlockPixels, n = std::min(kBlockPixels, npx - i0);
      if (n < kBlockPixels) {
        for (std::size_t i = i0; i < i0 + n; ++i)
          im.norm[i] = im.count[i] > 0 ? (im.mean[i] - t_min) * scale : 0.0f;
        continue;
      }
      for (std::size_t i = i0; i < i0 + kBlockPixels; i += 4) {
        const vi has = load(im.count + i) > 0;
        store(im.norm + i, select(has, (load(im.mean + i) - vmin) * vscale, vf{}));
      }
    }
  }
}

/// Adds the events to the accumulator, in event order, and marks their blocks and groups; returns
/// how many.
/// Events whose pixel is out of range are skipped. A function of its own with restrict pointers:
/// inside the caller's lambda every byte store to `blocks` made GCC reload all the pointers and
/// bounds per event.
FDV_NO_FUZZ_COVERAGE int accumulate(const std::int32_t* __restrict pixel,
                                    const float* __restrict t_s, std::size_t n, std::size_t npx,
                                    float* __restrict acc, std::uint8_t* __restrict blocks,
                                    std::uint8_t* __restrict groups_now) {
  int count = 0;
  // The accumulator is larger than L2 and events are scattered over it: prefetch ahead.
  constexpr std::size_t kPrefetch = 64;
  for (std::size_t k = 0; k < n; ++k) {
    if (k + kPrefetch < n)
      __builtin_prefetch(acc + 2 * std::min<std::size_t>(
                                       static_cast<std::uint32_t>(pixel[k + kPrefetch]), npx - 1));
    // Unsigned: negative indices wrap far out of range.
    const std::size_t p = static_cast<std::uint32_t>(pixel[k]);
    if (p >= npx) continue;
    acc[2 * p] += 1.0f;
    acc[2 * p + 1] += t_s[k];
    blocks[p / kBlockPixels] |= kNow;
    groups_now[p / kGroupPixels] = 1;
    ++count;
  }
  return count;
}

/// accumulate() over (pixel, time) pairs already known to be in range.
FDV_NO_FUZZ_COVERAGE void accumulate_pairs(const PixelTime* __restrict e, std::size_t n,
                                           float* __restrict acc, std::uint8_t* __restrict blocks,
                                           std::uint8_t* __restrict groups_now) {
  constexpr std::size_t kPrefetch = 64;
  for (std::size_t k = 0; k < n; ++k) {
    if (k + kPrefetch < n)
      __builtin_prefetch(acc + 2 * static_cast<std::size_t>(e[k + kPrefetch].pixel));
    const auto p = static_cast<std::size_t>(e[k].pixel);
    acc[2 * p] += 1.0f;
    acc[2 * p + 1] += e[k].t_s;
    blocks[p / kBlockPixels] |= kNow;
    groups_now[p / kGroupPixels] = 1;
  }
}

/// Splitting the work between threads. Part j owns the pixels [bound[j], bound[j + 1]) (whole
/// chunks of blocks) and accumulates only their events, so that no two threads write one pixel.
/// Events are first sorted by owner in parallel: part i takes the events [first_event[i],
/// first_event[i + 1]) and writes them, in event order, into its own range of `sorted` grouped by
/// owner (a counting sort; out-of-range pixels are dropped). Owner j then reads its group of each
/// range in order i = 0, 1, ...: every pixel still gets its events in event order, so Σt is the
/// same to the bit as in one pass. (Each part reading all events and skipping the other parts'
/// took longer than one thread: a branch mispredicted on half the events, and each part's
/// prefetches shared the other part's cache lines.)
struct Partition {
  std::array<std::size_t, kMaxImageParts + 1> bound{};        ///< pixel ranges of the owners
  std::array<std::size_t, kMaxImageParts + 1> first_event{};  ///< event ranges of the sorting parts
  /// group_begin[i][j]: where owner j's events of range i start in `sorted` (j = parts: the end).
  std::array<std::array<std::size_t, kMaxImageParts + 1>, kMaxImageParts> group_begin{};
  int parts = 1;

  int owner(std::size_t p) const {  // parts when out of range
    int j = 0;
    for (int b = 1; b <= parts; ++b) j += p >= bound[b];
    return j;
  }
};

/// sort_by_owner for two parts, the common case: the counts and both cursors stay in registers
/// (the general version's count and cursor arrays made a dependency chain through memory).
FDV_NO_FUZZ_COVERAGE void sort_by_owner_2(Partition& part, int i, const std::int32_t* pixel,
                                          const float* t_s, PixelTime* sorted) {
  const std::size_t e0 = part.first_event[i], e1 = part.first_event[i + 1];
  const std::size_t b1 = part.bound[1], b2 = part.bound[2];
  std::size_t second = 0, outside = 0;
  for (std::size_t k = e0; k < e1; ++k) {
    const std::size_t p = static_cast<std::uint32_t>(pixel[k]);
    second += p >= b1;
    outside += p >= b2;
  }
  auto& begin = part.group_begin[static_cast<std::size_t>(i)];
  begin[0] = e0;
  begin[1] = e1 - second;
  begin[2] = e1 - outside;
  std::size_t c0 = begin[0], c1 = begin[1];
  for (std::size_t k = e0; k < e1; ++k) {
    const std::size_t p = static_cast<std::uint32_t>(pixel[k]);
    if (p >= b2) continue;  // out of range: rare, predicted
    const std::size_t is_second = p >= b1;
    sorted[is_second ? c1 : c0] = {static_cast<std::int32_t>(p), t_s[k]};
    c0 += 1 - is_second;
    c1 += is_second;
  }
}

FDV_NO_FUZZ_COVERAGE void sort_by_owner(Partition& part, int i, const std::int32_t* pixel,
                                        const float* t_s, PixelTime* sorted) {
  if (part.parts == 2) return sort_by_owner_2(part, i, pixel, t_s, sorted);
  const std::size_t e0 = part.first_event[i], e1 = part.first_event[i + 1];
  std::array<std::size_t, kMaxImageParts + 1> count{};
  for (std::size_t k = e0; k < e1; ++k)
    ++count[static_cast<std::size_t>(part.owner(static_cast<std::uint32_t>(pixel[k])))];
  auto& begin = part.group_begin[static_cast<std::size_t>(i)];
  begin[0] = e0;
  for (int j = 0; j < part.parts; ++j) begin[j + 1] = begin[j] + count[j];
  std::array<std::size_t, kMaxImageParts + 1> cursor = begin;
  for (std::size_t k = e0; k < e1; ++k) {
    const std::size_t p = static_cast<std::uint32_t>(pixel[k]);
    sorted[cursor[static_cast<std::size_t>(part.owner(p))]++] = {static_cast<std::int32_t>(p),
                                                                 t_s[k]};
  }
}

}  // namespace

void prepare_time_images(TimeImages& out, int w, int h) {
  out.count.create(h, w, CV_32S);
  out.sum_time_s.create(h, w, CV_32F);
  out.mean_time_s.create(h, w, CV_32F);
  out.normalized.create(h, w, CV_32F);
  out.accumulator.create(h, w, CV_32FC2);
  const std::size_t npx = static_cast<std::size_t>(w) * h;
  const std::size_t n_blocks = (npx + kBlockPixels - 1) / kBlockPixels;
  // First use, new buffers or a new size: everything is blanked once; afterwards the images are
  // 0 outside the blocks the previous window marked.
  const std::array<const void*, 5> keys{out.count.data, out.sum_time_s.data, out.mean_time_s.data,
                                        out.normalized.data, out.accumulator.data};
  if (keys != out.buffer_keys || out.blocks.size() != n_blocks) {
    for (cv::Mat* m :
         {&out.count, &out.sum_time_s, &out.mean_time_s, &out.normalized, &out.accumulator})
      m->setTo(0);
    const std::size_t n_groups = (n_blocks + kGroupBlocks - 1) / kGroupBlocks;
    out.blocks.assign(n_blocks, 0);
    out.groups_now.assign(n_groups, 0);
    out.groups_before.assign(n_groups, 0);
    out.chunk_sums.assign((n_blocks + kChunkBlocks - 1) / kChunkBlocks, 0.0);
    out.buffer_keys = keys;
  }
}

void build_time_images(const CompensatedEventsView& view, TimeImages& out) {
  const int w = view.width, h = view.height;
  prepare_time_images(out, w, h);
  const std::size_t npx = static_cast<std::size_t>(w) * h;
  const std::size_t n_blocks = (npx + kBlockPixels - 1) / kBlockPixels;
  const Images im{out.accumulator.ptr<float>(), out.count.ptr<std::int32_t>(),
                  out.sum_time_s.ptr<float>(),  out.mean_time_s.ptr<float>(),
                  out.normalized.ptr<float>(),  out.groups_now.data(),
                  out.groups_before.data()};
  std::uint8_t* blocks = out.blocks.data();

  // Parts (Partition above): pixel ranges of whole chunks of blocks, so that the chunk sums do not
  // depend on the split either. Small windows are not worth a second thread.
  const std::size_t n = std::min(view.pixel.size(), view.t_s.size());
  const std::size_t n_chunks = (n_blocks + kChunkBlocks - 1) / kChunkBlocks;
  constexpr std::size_t kMinEventsPerPart = 16'384;
  Partition split;
  split.parts = static_cast<int>(std::clamp<std::size_t>(
      std::min(n / kMinEventsPerPart, n_chunks), 1, std::clamp(view.threads, 1, kMaxImageParts)));
  const int parts = split.parts;
  std::array<std::size_t, kMaxImageParts + 1> first_block{};
  for (int i = 0; i <= parts; ++i) {
    first_block[i] = std::min(n_blocks, n_chunks * static_cast<std::size_t>(i) /
                                            static_cast<std::size_t>(parts) * kChunkBlocks);
    split.bound[i] = std::min(npx, first_block[i] * kBlockPixels);
    split.first_event[i] = n * static_cast<std::size_t>(i) / static_cast<std::size_t>(parts);
  }
  std::array<Extremes, kMaxImageParts> extremes;
  std::array<int, kMaxImageParts> events{};
  const std::int32_t* pixel = view.pixel.data();
  const float* t_s = view.t_s.data();
  if (parts == 1) {
    events[0] = accumulate(pixel, t_s, n, npx, im.acc, blocks, im.groups_now);
    extremes[0] = pass1(im, blocks, 0, n_blocks, npx, out.chunk_sums.data());
  } else {
    if (out.sorted.size() < n)
      out.sorted.resize(std::bit_ceil(n));  // powers of two, as the compensator's
    PixelTime* sorted = out.sorted.data();
    run_parts(parts, [&](int i) { sort_by_owner(split, i, pixel, t_s, sorted); });
    run_parts(parts, [&](int j) {
      const auto owner = static_cast<std::size_t>(j);
      std::size_t mine = 0;
      for (int i = 0; i < parts; ++i) {
        const auto& begin = split.group_begin[static_cast<std::size_t>(i)];
        accumulate_pairs(sorted + begin[owner], begin[owner + 1] - begin[owner], im.acc, blocks,
                         im.groups_now);
        mine += begin[owner + 1] - begin[owner];
      }
      events[owner] = static_cast<int>(mine);
      extremes[owner] =
          pass1(im, blocks, first_block[j], first_block[j + 1], npx, out.chunk_sums.data());
    });
  }
  Extremes x;
  int n_events = 0;
  for (int i = 0; i < parts; ++i) {
    x.t_min = std::min(x.t_min, extremes[i].t_min);
    x.t_max = std::max(x.t_max, extremes[i].t_max);
    x.pixels += extremes[i].pixels;
    x.blocks_visited += extremes[i].blocks_visited;
    n_events += events[i];
  }
  const bool any = x.pixels > 0;
  const float t_min = any ? x.t_min : 0.0f, t_max = any ? x.t_max : 0.0f;
  const double range = static_cast<double>(t_max) - static_cast<double>(t_min);
  const double inv = any && range > 0 ? 1.0 / range : 0.0;
  run_parts(parts, [&](int part) {
    pass2(im, blocks, first_block[part], first_block[part + 1], npx, t_min,
          static_cast<float>(inv));
  });

  // Pass 2 made this window's groups the "before" ones: the rows of the first to the last.
  const auto& groups = out.groups_before;
  const auto marked = [](std::uint8_t g) { return g != 0; };
  const auto first = std::find_if(groups.begin(), groups.end(), marked);
  out.event_rows = cv::Range(0, 0);
  if (first != groups.end()) {
    const auto g0 = static_cast<std::size_t>(first - groups.begin());
    const auto past_last = static_cast<std::size_t>(
        groups.rend() - std::find_if(groups.rbegin(), groups.rend(), marked));
    const auto width = static_cast<std::size_t>(w);
    const std::size_t p0 = g0 * kGroupPixels, p1 = std::min(npx, past_last * kGroupPixels);
    out.event_rows =
        cv::Range(static_cast<int>(p0 / width), static_cast<int>((p1 - 1) / width + 1));
  }

  double sum_t = 0;
  for (double c : out.chunk_sums) sum_t += c;
  out.events = n_events;
  out.pixels_with_events = x.pixels;
  out.blocks_visited = x.blocks_visited;
  out.t_min_s = t_min;
  out.t_max_s = t_max;
  // mean(N) = (mean(T) − min T) / (max T − min T) over pixels with events (N is affine in T).
  out.mean_normalized = any ? (sum_t / x.pixels - t_min) * inv : 0.0;
}

}  // namespace fdv
