#include "fdv/detection/segmentation.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>

#include "fdv/core/fuzz_coverage.h"
#include "fdv/core/lanes.h"
#include "fdv/core/thread_pool.h"

namespace fdv {
namespace {

// Why hand-written passes instead of cv::threshold / cv::compare / cv::sepFilter2D / cv::erode /
// cv::dilate (the earlier version, docs/BENCHMARKS.md): those allocate at each call (filter
// engines, row buffers, kernels) and visit the whole image, while S is nonzero on a small part of
// it. Each pass here is a plain row loop that GCC vectorises; tests/detection/opencv_equivalence_test.cpp
// compares them with the OpenCV calls.

/// The row pass of a separable operation: out[x] = op over line[x .. x + 2h] (left to right),
/// for x in [0, n); `line` holds the input padded by h on each side.
template <class Op>
void row_pass(const float* line, int n, int h, float* out, Op op) {
  if (h == 1) {  // the default 3x3 kernels: one fused loop, the same order of operations
    for (int x = 0; x < n; ++x) out[x] = op(op(line[x], line[x + 1]), line[x + 2]);
    return;
  }
  std::memcpy(out, line, static_cast<std::size_t>(n) * sizeof(float));
  for (int j = 1; j <= 2 * h; ++j)
    for (int x = 0; x < n; ++x) out[x] = op(out[x], line[x + j]);
}

/// Copies in[i0, i1) of a row that is 0 elsewhere into `line`, which then covers [o0 − h, o1 + h).
float* pad_row(const float* in, int i0, int i1, int o0, int o1, int h, std::vector<float>& line) {
  const int n = o1 - o0 + 2 * h;
  std::fill(line.begin(), line.begin() + n, 0.0f);
  const int c0 = std::max(i0, o0 - h), c1 = std::min(i1, o1 + h);
  if (c1 > c0) std::memcpy(&line[static_cast<std::size_t>(c0 - (o0 - h))], in + c0, static_cast<std::size_t>(c1 - c0) * sizeof(float));
  return line.data();
}

constexpr auto kAdd = [](float a, float b) { return a + b; };
constexpr auto kMin = [](float a, float b) { return std::min(a, b); };
constexpr auto kMax = [](float a, float b) { return std::max(a, b); };

/// Rows of a strip buffer addressed by image row.
struct StripRows {
  cv::Mat* m;
  int base;  // image row of the buffer's row 0
  float* operator()(int y) const { return m->ptr<float>(y - base); }
};

constexpr auto kKeep = [](float v) { return v; };

/// out = post(op over rows [lo, hi] of `in` (columns [c, c + n)), top to bottom); `fill` when
/// lo > hi.
template <class Op, class Post = decltype(kKeep)>
void column_pass(const StripRows& in, int lo, int hi, int c, int n, float* out, float fill, Op op, Post post = kKeep) {
  if (lo > hi) {
    std::fill(out, out + n, fill);
    return;
  }
  const float* r0 = in(lo) + c;
  if (hi - lo == 2) {  // three rows (3x3 kernels inside the image): one fused loop
    const float *r1 = in(lo + 1) + c, *r2 = in(lo + 2) + c;
    for (int x = 0; x < n; ++x) out[x] = post(op(op(r0[x], r1[x]), r2[x]));
    return;
  }
  std::memcpy(out, r0, static_cast<std::size_t>(n) * sizeof(float));
  for (int y = lo + 1; y <= hi; ++y) {
    const float* s = in(y) + c;
    for (int x = 0; x < n; ++x) out[x] = op(out[x], s[x]);
  }
  for (int x = 0; x < n; ++x) out[x] = post(out[x]);
}

constexpr int kStripRows = 32;

/// max of p[0, n), n ≥ 1 (no NaN), four lanes at a time in four independent chains (one chain
/// waited on each comparison's latency). The maximum is exact in any order.
FDV_NO_FUZZ_COVERAGE inline float row_max(const float* p, int n) {
  using lanes::vf;
  int x = 0;
  float mx = p[0];
  if (n >= 16) {
    vf a = lanes::load(p), b = lanes::load(p + 4), c = lanes::load(p + 8), d = lanes::load(p + 12);
    const auto vmax = [](vf u, vf v) { return lanes::select(v > u, v, u); };
    for (x = 16; x + 16 <= n; x += 16) {
      a = vmax(a, lanes::load(p + x));
      b = vmax(b, lanes::load(p + x + 4));
      c = vmax(c, lanes::load(p + x + 8));
      d = vmax(d, lanes::load(p + x + 12));
    }
    const vf v = vmax(vmax(a, b), vmax(c, d));
    mx = std::max(std::max(v[0], v[1]), std::max(v[2], v[3]));
  }
  for (; x < n; ++x) mx = std::max(mx, p[x]);
  return mx;
}

/// The largest value seen so far and the first row (top to bottom) that holds it.
struct RowMaximum {
  float value = -std::numeric_limits<float>::infinity();
  int y = -1;
  void add(const float* row, int n, int row_y) {
    const float m = row_max(row, n);
    if (m > value) {
      value = m;
      y = row_y;
    }
  }
};

/// P = (open_{2h2+1}(mean_{2h1+1}(S)))² on r1 = (s_bounds grown by h1) ∩ image, which holds every
/// nonzero value of P (the opening never extends the support of the mean); S is 0 outside
/// s_bounds. Writes P only inside r1. Works through r1 in strips of kStripRows output rows, each
/// with the rows above and below it needs (h1 + 2·h2 each side, recomputed), so that the
/// intermediate images stay in the cache: `a`, `b` are strip buffers of at least
/// kStripRows + 2·(h1 + 2·h2) rows of S's width. Of r1's strips it does those with index in
/// [n·part/parts, n·(part + 1)/parts): the strips are independent, so parts may run on different
/// threads (each with its own a, b, line) and give the same P. `best` gets the maximum of the
/// rows written and the first of them that holds it (while the row is in the cache: the
/// detector's first candidate search costs nothing more). Returns r1.
// AVX2 clone (chosen at run time): the plain loops below vectorise 8 lanes wide instead of 4. Lane-wise
// adds, products, minima and maxima, no FMA: the same results as the baseline build, to the bit.
FDV_AVX2_CLONES FDV_NO_FUZZ_COVERAGE __attribute__((flatten)) cv::Rect
open_mean_square(const cv::Mat& S, const cv::Rect& s_bounds, int h1, int h2, cv::Mat& P, cv::Mat& a, cv::Mat& b,
                 std::vector<float>& line, RowMaximum& best, int part = 0, int parts = 1) {
  const cv::Rect image(0, 0, S.cols, S.rows);
  const cv::Rect r = s_bounds & image;
  if (r.area() == 0) return {};
  const cv::Rect r1 = cv::Rect(r.x - h1, r.y - h1, r.width + 2 * h1, r.height + 2 * h1) & image;
  // The eroded image is 0 outside r2 (r1 shrunk by h2 on every side: the mean is 0 outside r1 and
  // beyond the image), and its windows there stay inside r1.
  const cv::Rect r2(r1.x + h2, r1.y + h2, r1.width - 2 * h2, r1.height - 2 * h2);
  const bool eroded_any = r2.width > 0 && r2.height > 0;
  const int x0 = r1.x, x1 = r1.x + r1.width, n = r1.width;
  const int r_end = r.y + r.height, r2_end = r2.y + r2.height;
  const int halo = h1 + 2 * h2;
  CV_Assert(a.rows >= kStripRows + 2 * halo && b.rows >= kStripRows + 2 * halo && a.cols >= S.cols &&
            b.cols >= S.cols && line.size() >= static_cast<std::size_t>(S.cols + 4 * halo + 2));
  const float scale = static_cast<float>(1.0 / ((2 * h1 + 1) * (2 * h1 + 1)));

  const int n_strips = (r1.height + kStripRows - 1) / kStripRows;
  const int first = n_strips * part / parts, last = n_strips * (part + 1) / parts;
  for (int ya = r1.y + first * kStripRows; ya < r1.y + std::min(r1.height, last * kStripRows); ya += kStripRows) {
    const int yb = std::min(ya + kStripRows, r1.y + r1.height);  // output rows [ya, yb)
    const StripRows A{&a, ya - halo}, B{&b, ya - halo};
    if (!eroded_any) {
      for (int y = ya; y < yb; ++y) {
        std::fill(P.ptr<float>(y) + x0, P.ptr<float>(y) + x1, 0.0f);
        best.add(P.ptr<float>(y) + x0, n, y);
      }
      continue;
    }
    // Rows each stage needs for this strip (inclusive ranges).
    const int e_lo = std::max(ya - h2, r2.y), e_hi = std::min(yb - 1 + h2, r2_end - 1);
    const int m_lo = e_lo - h2, m_hi = e_hi + h2;  // inside r1
    const int s_lo = std::max(m_lo - h1, r.y), s_hi = std::min(m_hi + h1, r_end - 1);
    // Mean filter, zero beyond the image: row sums of S (0 outside r), then the sum of the
    // 2h1 + 1 row sums (rows without S add exact zeros and are skipped), times 1/k1².
    for (int y = s_lo; y <= s_hi; ++y)
      row_pass(pad_row(S.ptr<float>(y), r.x, r.x + r.width, x0, x1, h1, line), n, h1, A(y) + x0, kAdd);
    const auto times_scale = [scale](float v) { return v * scale; };
    for (int y = m_lo; y <= m_hi; ++y)
      column_pass(A, std::max(y - h1, s_lo), std::min(y + h1, s_hi), x0, n, B(y) + x0, 0.0f, kAdd, times_scale);
    // Erosion: row minima over r2's columns, then column minima over r2's rows.
    for (int y = m_lo; y <= m_hi; ++y) row_pass(B(y) + r1.x, r2.width, h2, A(y) + r2.x, kMin);
    for (int y = e_lo; y <= e_hi; ++y) column_pass(A, y - h2, y + h2, r2.x, r2.width, B(y) + r2.x, 0.0f, kMin);
    // Dilation of the eroded image (0 outside r2) back over r1, then the square.
    for (int y = e_lo; y <= e_hi; ++y)
      row_pass(pad_row(B(y), r2.x, r2.x + r2.width, x0, x1, h2, line), n, h2, A(y) + x0, kMax);
    const auto square = [](float v) { return v * v; };
    for (int y = ya; y < yb; ++y) {
      column_pass(A, std::max(y - h2, e_lo), std::min(y + h2, e_hi), x0, n, P.ptr<float>(y) + x0, 0.0f, kMax, square);
      best.add(P.ptr<float>(y) + x0, n, y);
    }
  }
  return r1;
}

}  // namespace

void zero_rect(cv::Mat& m, const cv::Rect& r) {
  CV_Assert(m.elemSize() == 4 && m.dims == 2);
  const cv::Rect c = r & cv::Rect(0, 0, m.cols, m.rows);
  for (int y = c.y; y < c.y + c.height; ++y)
    std::memset(m.ptr<std::uint8_t>(y) + 4 * static_cast<std::size_t>(c.x), 0, 4 * static_cast<std::size_t>(c.width));
}

FDV_NO_FUZZ_COVERAGE MaxLocation first_maximum(const cv::Mat& m, const cv::Rect& r) {
  CV_Assert(m.type() == CV_32F);
  const cv::Rect c = r & cv::Rect(0, 0, m.cols, m.rows);
  MaxLocation best{0, c.tl()};
  if (c.area() == 0) return best;
  int best_y = c.y;
  best.value = m.ptr<float>(c.y)[c.x];
  for (int y = c.y; y < c.y + c.height; ++y) {
    const float v = row_max(m.ptr<float>(y) + c.x, c.width);
    if (v > best.value) {
      best.value = v;
      best_y = y;
    }
  }
  const float* p = m.ptr<float>(best_y) + c.x;
  int x = 0;
  while (p[x] != best.value) ++x;
  best.at = {c.x + x, best_y};
  return best;
}

double adaptive_threshold(double mean_normalized, double omega_rad_s, double speed_m_s, const DetectorOptions& o) {
  return mean_normalized + o.threshold_a_s_per_rad * omega_rad_s + o.threshold_b_s_per_m * speed_m_s + o.threshold_c;
}

namespace {

// AVX2 clone, as open_mean_square.
/// segment() over the rows [y0, y1) of S (created).
FDV_AVX2_CLONES FDV_NO_FUZZ_COVERAGE SegmentResult
segment_rows(const TimeImages& ti, float th, std::int32_t min_count, cv::Mat& S, int y0, int y1) {
  SegmentResult res;
  int x_lo = S.cols, x_hi = -1, y_lo = S.rows, y_hi = -1;
  for (int y = y0; y < y1; ++y) {
    const float* n = ti.normalized.ptr<float>(y);
    const std::int32_t* c = ti.count.ptr<std::int32_t>(y);
    float* s = S.ptr<float>(y);
    int kept = 0;
    for (int x = 0; x < S.cols; ++x) {  // branch-free, so that GCC vectorises it
      const bool keep = (n[x] > th) & (c[x] >= min_count);
      const float v = keep ? n[x] : 0.0f;
      s[x] = v;
      kept += static_cast<int>(v != 0.0f);
    }
    if (kept == 0) continue;
    res.pixels += kept;
    int first = 0, last = S.cols - 1;
    while (s[first] == 0.0f) ++first;
    while (s[last] == 0.0f) --last;
    x_lo = std::min(x_lo, first);
    x_hi = std::max(x_hi, last);
    y_lo = std::min(y_lo, y);
    y_hi = y;
  }
  if (res.pixels > 0) res.bounds = {x_lo, y_lo, x_hi - x_lo + 1, y_hi - y_lo + 1};
  return res;
}

}  // namespace

SegmentResult segment(const TimeImages& ti, double theta, int min_pixel_events, cv::Mat& S,
                      int threads, std::optional<cv::Rect> s_nonzero) {
  CV_Assert(ti.normalized.type() == CV_32F && ti.count.type() == CV_32S && ti.normalized.size() == ti.count.size());
  CV_Assert(!s_nonzero || (S.type() == CV_32F && S.size() == ti.normalized.size()));
  S.create(ti.normalized.size(), CV_32F);
  // S = N where N ≥ θ (the float comparison N > the float just below θ, as cv::THRESH_TOZERO did)
  // and I ≥ min_pixel_events. Pixels without events have N = 0 and stay 0 whatever θ: only the
  // rows that can hold events need computing when S is known to be zero elsewhere.
  const float th = std::nextafter(static_cast<float>(theta), -std::numeric_limits<float>::infinity());
  int y0 = 0, y1 = S.rows;
  if (s_nonzero) {
    y0 = std::clamp(ti.event_rows.start, 0, S.rows);
    y1 = std::clamp(ti.event_rows.end, y0, S.rows);
    const cv::Rect old = *s_nonzero & cv::Rect(0, 0, S.cols, S.rows);
    zero_rect(S, cv::Rect(old.x, old.y, old.width,
                          std::max(0, std::min(old.y + old.height, y0) - old.y)));
    const int below = std::max(old.y, y1);
    zero_rect(S, cv::Rect(old.x, below, old.width, std::max(0, old.y + old.height - below)));
  }
  // Parts: bands of rows, their results merged (the same as one pass).
  const int rows = y1 - y0;
  const int parts = std::clamp(std::min(threads, rows / kStripRows), 1, kMaxImageParts);
  std::array<SegmentResult, kMaxImageParts> part_res;
  run_parts(parts, [&](int i) {
    part_res[i] = segment_rows(ti, th, min_pixel_events, S, y0 + rows * i / parts,
                               y0 + rows * (i + 1) / parts);
  });
  SegmentResult res;
  for (int i = 0; i < parts; ++i) {
    if (part_res[i].pixels == 0) continue;
    res.bounds = res.pixels == 0 ? part_res[i].bounds : res.bounds | part_res[i].bounds;
    res.pixels += part_res[i].pixels;
  }
  return res;
}

Preprocessor::Preprocessor(const DetectorOptions& o) : h_mean_(o.mean_filter_px / 2), h_open_(o.opening_px / 2) {
  CV_Assert(o.mean_filter_px >= 1 && o.mean_filter_px % 2 == 1 && o.opening_px >= 1 && o.opening_px % 2 == 1);
}

const cv::Mat& Preprocessor::run(const cv::Mat& S, const cv::Rect& s_bounds, int threads) {
  CV_Assert(S.type() == CV_32F);
  if (P_.size() != S.size()) allocate(S.size());
  // Zero what the last call wrote outside what this one writes (r1 of open_mean_square).
  const cv::Rect image(0, 0, S.cols, S.rows), r = s_bounds & image;
  const cv::Rect r1 = r.area() > 0 ? cv::Rect(r.x - h_mean_, r.y - h_mean_, r.width + 2 * h_mean_,
                                              r.height + 2 * h_mean_) & image
                                   : cv::Rect();
  const cv::Rect& old = written_;
  if (r1.area() == 0 || (old & r1).area() == 0) {
    clear();
  } else {
    const int top = std::max(old.y, r1.y), bottom = std::min(old.y + old.height, r1.y + r1.height);
    auto zero = [&](int x0, int y0, int x1, int y1) {
      if (x1 > x0 && y1 > y0) zero_rect(P_, cv::Rect(x0, y0, x1 - x0, y1 - y0));
    };
    zero(old.x, old.y, old.x + old.width, top);                           // above r1
    zero(old.x, bottom, old.x + old.width, old.y + old.height);           // below r1
    zero(old.x, top, std::min(old.x + old.width, r1.x), bottom);          // left of r1
    zero(std::max(old.x, r1.x + r1.width), top, old.x + old.width, bottom);  // right of r1
  }
  // Parts: r1's strips shared out (open_mean_square), each with its own strip buffers.
  const int parts = std::clamp(std::min(threads, (r1.height + kStripRows - 1) / kStripRows), 1, kMaxImageParts);
  while (static_cast<int>(strips_.size()) < parts) add_strip_buffers(S.cols);  // first use only
  std::array<RowMaximum, kMaxImageParts> part_best;
  run_parts(parts, [&](int i) {
    StripBuffers& sb = strips_[static_cast<std::size_t>(i)];
    open_mean_square(S, s_bounds, h_mean_, h_open_, P_, sb.a, sb.b, sb.line, part_best[i], i, parts);
  });
  written_ = r1;
  // The parts are bands from top to bottom: the first strictly larger one keeps the first row.
  RowMaximum best;
  for (int i = 0; i < parts; ++i)
    if (part_best[i].value > best.value) best = part_best[i];
  first_max_ = {0.0f, r1.tl()};
  if (best.y >= 0) {
    const float* row = P_.ptr<float>(best.y) + r1.x;
    int x = 0;
    while (row[x] != best.value) ++x;
    first_max_ = {best.value, {r1.x + x, best.y}};
  }
  return P_;
}

void Preprocessor::allocate(cv::Size size) {
  P_.create(size, CV_32F);
  P_.setTo(0);
  const std::size_t keep = std::max<std::size_t>(1, strips_.size());
  strips_.clear();
  while (strips_.size() < keep) add_strip_buffers(size.width);
  written_ = {};
  first_max_ = {};
}

void Preprocessor::add_strip_buffers(int width) {
  const int strip_rows = kStripRows + 2 * (h_mean_ + 2 * h_open_);
  StripBuffers& sb = strips_.emplace_back();
  sb.a.create(strip_rows, width, CV_32F);
  sb.b.create(strip_rows, width, CV_32F);
  sb.line.assign(static_cast<std::size_t>(width + 4 * (h_mean_ + 2 * h_open_) + 2), 0.0f);
}

void Preprocessor::clear() {
  zero_rect(P_, written_);
  written_ = {};
  first_max_ = {};
}

void preprocess(const cv::Mat& S, const DetectorOptions& o, cv::Mat& P, cv::Mat& scratch) {
  CV_Assert(S.type() == CV_32F);
  const int h1 = o.mean_filter_px / 2, h2 = o.opening_px / 2, strip_rows = kStripRows + 2 * (h1 + 2 * h2);
  P.create(S.size(), CV_32F);
  scratch.create(2 * strip_rows, S.cols, CV_32F);
  cv::Mat a = scratch.rowRange(0, strip_rows), b = scratch.rowRange(strip_rows, 2 * strip_rows);
  std::vector<float> line(static_cast<std::size_t>(S.cols + 4 * (h1 + 2 * h2) + 2));
  RowMaximum best;
  if (open_mean_square(S, cv::Rect(0, 0, S.cols, S.rows), h1, h2, P, a, b, line, best).area() == 0) P.setTo(0);
}

}  // namespace fdv
