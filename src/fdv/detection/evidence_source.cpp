#include "fdv/detection/evidence_source.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "fdv/core/time.h"

namespace fdv {

std::string EvidenceSourceOptions::validate() const {
  std::ostringstream why;
  if (!(cell_px >= 2 && cell_px <= 64)) why << "evidence_cell_px must be in [2, 64], got " << cell_px;
  else if (!(signal_sigma > 0 && signal_sigma <= 100)) why << "evidence_signal_sigma must be in (0, 100], got " << signal_sigma;
  else if (!(threshold > 0 && std::isfinite(threshold))) why << "evidence_threshold must be finite and > 0, got " << threshold;
  else if (!(max_window_llr > 0 && std::isfinite(max_window_llr)))
    why << "evidence_max_window_llr must be finite and > 0, got " << max_window_llr;
  else if (!(background_weight > 0 && background_weight <= 1))
    why << "evidence_background_weight must be in (0, 1], got " << background_weight;
  else if (!(min_background >= 0 && std::isfinite(min_background)))
    why << "evidence_min_background must be finite and ≥ 0, got " << min_background;
  else if (!(min_travel_cells >= 0 && min_travel_cells <= 5))
    why << "evidence_min_travel_cells must be in [0, 5] cells, got " << min_travel_cells;
  else if (!(warmup_windows >= 0 && warmup_windows <= 1000))
    why << "evidence_warmup_windows must be in [0, 1000], got " << warmup_windows;
  else if (!(max_surround_ratio >= 0 && std::isfinite(max_surround_ratio)))
    why << "evidence_max_surround_ratio must be finite and ≥ 0, got " << max_surround_ratio;
  else if (!(min_isolation >= 0 && std::isfinite(min_isolation)))
    why << "evidence_min_isolation must be finite and ≥ 0, got " << min_isolation;
  return why.str();
}

void EvidenceGrid::reset(int cols, int rows) {
  for (cv::Mat* m :
       {&mean_, &variance_, &evidence_, &llr_, &excess_, &predicted_evidence_, &predicted_mean_, &predicted_variance_,
        &best_offer_})
    m->create(rows, cols, CV_32F), m->setTo(0);
  offer_from_.create(rows, cols, CV_32SC2);
  for (cv::Mat* m : {&travel_, &predicted_travel_}) m->create(rows, cols, CV_32FC2), m->setTo(0);
  windows_ = 0;
}

void EvidenceGrid::break_paths() {
  std::fill(evidence_.begin<float>(), evidence_.end<float>(), 0.f);  // setTo allocates
  std::fill(travel_.begin<cv::Vec2f>(), travel_.end<cv::Vec2f>(), cv::Vec2f(0, 0));
}

void EvidenceGrid::update(const cv::Mat& fired, const cv::Mat& previous) {
  CV_Assert(fired.type() == CV_32F && fired.size() == evidence_.size());
  const EvidenceSourceOptions& o = options_;
  if (windows_++ == 0) {
    fired.copyTo(mean_);
    std::fill(excess_.begin<float>(), excess_.end<float>(), 0.f);
    variance_.setTo(0);
    return;
  }
  // Every map as it was a window ago, moved by the ego-motion onto this window's cells.
  if (previous.empty()) {
    evidence_.copyTo(predicted_evidence_);
    travel_.copyTo(predicted_travel_);
    mean_.copyTo(predicted_mean_);
    variance_.copyTo(predicted_variance_);
  } else {
    // Nearest cell, not bilinear: resampling every window would blur each cell's history into its
    // neighbours' (a textured cell's mean sinking towards its empty neighbours'). By hand, not
    // cv::remap, which allocates its buffers on every call.
    const int rows = fired.rows, cols = fired.cols;
    for (int y = 0; y < rows; ++y) {
      const cv::Vec2f* from = previous.ptr<cv::Vec2f>(y);
      float* evidence = predicted_evidence_.ptr<float>(y);
      cv::Vec2f* travel = predicted_travel_.ptr<cv::Vec2f>(y);
      float* mean = predicted_mean_.ptr<float>(y);
      float* variance = predicted_variance_.ptr<float>(y);
      for (int x = 0; x < cols; ++x) {
        const int px = static_cast<int>(std::lround(from[x][0])), py = static_cast<int>(std::lround(from[x][1]));
        const bool inside = px >= 0 && py >= 0 && px < cols && py < rows;  // else it entered the view
        const int cx = std::clamp(px, 0, cols - 1), cy = std::clamp(py, 0, rows - 1);
        evidence[x] = inside ? evidence_.ptr<float>(py)[px] : 0.f;
        travel[x] = inside ? travel_.ptr<cv::Vec2f>(py)[px] : cv::Vec2f(0, 0);
        mean[x] = mean_.ptr<float>(cy)[cx];
        variance[x] = variance_.ptr<float>(cy)[cx];
      }
    }
  }
  // The window's activity against the expected: the camera speeding up, or a scene-wide change
  // of light, raises every cell alike and is no object. b_min a cell in both sums: in a nearly
  // empty scene the object itself must not set g. Never below 1: when the scene quietens (a
  // moving person stopping), the cells still firing must not look raised.
  const double prior = o.min_background * static_cast<double>(fired.total());
  double fired_sum = prior, expected_sum = prior;  // by hand: cv::sum allocates its buffers
  for (int y = 0; y < fired.rows; ++y) {
    const float* n = fired.ptr<float>(y);
    const float* m = predicted_mean_.ptr<float>(y);
    for (int x = 0; x < fired.cols; ++x) fired_sum += n[x], expected_sum += m[x];
  }
  const float gain = static_cast<float>(std::max(1.0, fired_sum / expected_sum));
  const bool learning = windows_ <= o.warmup_windows;
  const float delta = static_cast<float>(o.signal_sigma), llr_max = static_cast<float>(o.max_window_llr);
  const float b_min = static_cast<float>(o.min_background), keep = static_cast<float>(kTravelMemory);
  // A path holds at most 2h: the evidence of an object that left fades within a few windows.
  const float L_max = 2 * static_cast<float>(o.threshold);
  // A running average over the first 1/α windows, then exponential.
  const float alpha = std::max(static_cast<float>(o.background_weight), 1.f / static_cast<float>(windows_));
  const int rows = fired.rows, cols = fired.cols;
  // Each path a window ago offers itself to the 3 × 3 cells around where it goes next over the
  // scene: its own cell moved by its recent step, (1 − 0.8)·T (an object moves at most a cell a
  // window from where its motion predicts it). Each cell takes the best offer, its own cell's on a tie.
  // std::fill, not setTo, which allocates a buffer for the scalar on every call.
  std::fill(best_offer_.begin<float>(), best_offer_.end<float>(), 0.f);
  std::fill(offer_from_.begin<cv::Vec2i>(), offer_from_.end<cv::Vec2i>(), cv::Vec2i(-1, -1));
  for (int y = 0; y < rows; ++y) {
    const float* offers = predicted_evidence_.ptr<float>(y);
    const cv::Vec2f* travels = predicted_travel_.ptr<cv::Vec2f>(y);
    for (int x = 0; x < cols; ++x) {
      const float offer = offers[x];
      if (!(offer > 0)) continue;
      const cv::Vec2f step = (1 - keep) * travels[x];
      const int cx = x + static_cast<int>(std::lround(step[0])), cy = y + static_cast<int>(std::lround(step[1]));
      for (int ty = std::max(cy - 1, 0); ty <= std::min(cy + 1, rows - 1); ++ty)
        for (int tx = std::max(cx - 1, 0); tx <= std::min(cx + 1, cols - 1); ++tx) {
          float& best = best_offer_.at<float>(ty, tx);
          const bool own = tx == x && ty == y;
          if (offer > best || (own && offer == best)) best = offer, offer_from_.at<cv::Vec2i>(ty, tx) = cv::Vec2i(x, y);
        }
    }
  }
  for (int y = 0; y < rows; ++y) {
    const float* n = fired.ptr<float>(y);
    const float* m = predicted_mean_.ptr<float>(y);
    const float* v = predicted_variance_.ptr<float>(y);
    const float* offer = best_offer_.ptr<float>(y);
    const cv::Vec2i* from = offer_from_.ptr<cv::Vec2i>(y);
    float* L = evidence_.ptr<float>(y);
    cv::Vec2f* travel = travel_.ptr<cv::Vec2f>(y);
    float* l = llr_.ptr<float>(y);
    float* excess = excess_.ptr<float>(y);
    float* m_next = mean_.ptr<float>(y);
    float* v_next = variance_.ptr<float>(y);
    for (int x = 0; x < cols; ++x) {
      const float mu = gain * m[x];
      const float sigma = std::sqrt(std::max(gain * gain * v[x], mu) + b_min);
      const float z = (n[x] - mu) / sigma;
      excess[x] = std::max(n[x] - mu - sigma, 0.f);
      l[x] = learning ? 0.f : std::min(delta * z - 0.5f * delta * delta, llr_max);
      L[x] = std::clamp(offer[x] + l[x], 0.f, L_max);
      const cv::Vec2i f = from[x];
      const bool continues = L[x] > 0 && f[0] >= 0;
      const cv::Vec2f step(static_cast<float>(x - (continues ? f[0] : x)), static_cast<float>(y - (continues ? f[1] : y)));
      travel[x] = continues ? keep * predicted_travel_.at<cv::Vec2f>(f[1], f[0]) + step : cv::Vec2f(0, 0);
      const float e = n[x] - m[x];
      m_next[x] = m[x] + alpha * e;
      v_next[x] = (1 - alpha) * (v[x] + alpha * e * e);
    }
  }
}

EvidenceSource::EvidenceSource(const DetectorOptions& options) : options_(options), grid_(options.evidence) {}

void EvidenceSource::allocate(int width, int height) {
  const int c = options_.evidence.cell_px;
  width_ = width;
  height_ = height;
  cols_ = (width + c - 1) / c;
  rows_ = (height + c - 1) / c;
  grid_.reset(cols_, rows_);
  fired_.create(rows_, cols_, CV_32F);
  previous_.create(rows_, cols_, CV_32FC2);
  moved_ = false;
  coarse_.create((rows_ + kCoarseStep - 1) / kCoarseStep + 1, (cols_ + kCoarseStep - 1) / kCoarseStep + 1, CV_32FC2);
  updated_ = false;
}

bool EvidenceSource::begin_window(const SourceWindow& in) {
  const CompensatedEventsView& v = in.events;
  if (!v.new_evidence) return false;
  if (v.width != width_ || v.height != height_) allocate(v.width, v.height);
  // A window that did not reach the sources (too few events, flooded) breaks every path; the
  // background is kept, without the ego-motion of the windows missed.
  const bool follows = grid_.windows() > 0 && v.t_start == last_end_;
  if (grid_.windows() > 0 && !follows) grid_.break_paths();
  count_fired(in);
  grid_.update(fired_, follows && moved_ ? previous_ : cv::Mat());
  predict_motion(in);
  last_start_ = v.t_start;
  last_end_ = v.t_end;
  updated_ = true;
  return true;
}

void EvidenceSource::count_fired(const SourceWindow& in) {
  // Fired pixels, not events: a hot pixel or a flickering one counts once however often it fires.
  // Per row of cells, each column's fired pixels first (a loop the compiler vectorises: the sums
  // are 16-bit, so they cannot alias the count image), then the columns of each cell.
  const int c = options_.evidence.cell_px, width = width_, height = height_;
  const cv::Mat& I = in.ti.count;
  column_fired_.resize(static_cast<std::size_t>(width));
  std::uint16_t* columns = column_fired_.data();
  for (int cy = 0; cy < rows_; ++cy) {
    std::fill(column_fired_.begin(), column_fired_.end(), std::uint16_t{0});
    for (int y = cy * c; y < std::min((cy + 1) * c, height); ++y) {
      const std::int32_t* row = I.ptr<std::int32_t>(y);
      for (int x = 0; x < width; ++x) columns[x] = static_cast<std::uint16_t>(columns[x] + (row[x] > 0));
    }
    float* cells = fired_.ptr<float>(cy);
    for (int cell = 0; cell < cols_; ++cell) {
      int fired = 0;
      for (int x = cell * c; x < std::min((cell + 1) * c, width); ++x) fired += columns[x];
      cells[cell] = static_cast<float>(fired);
    }
  }
}

void EvidenceSource::predict_motion(const SourceWindow& in) {
  const CompensatedEventsView& v = in.events;
  moved_ = static_cast<bool>(v.observed_at);
  if (!moved_) return;
  // The displacement by the next window's start of every kCoarseStep-th cell's centre, then
  // bilinear between them: the ego-motion's image flow is smooth over a few cells.
  const double c = options_.evidence.cell_px, length_s = to_seconds(v.t_end - v.t_start);
  const auto coarse_cell = [&](int k, int cells) { return std::min(k * kCoarseStep, cells - 1); };
  for (int j = 0; j < coarse_.rows; ++j)
    for (int i = 0; i < coarse_.cols; ++i) {
      const Eigen::Vector2d centre((coarse_cell(i, cols_) + 0.5) * c, (coarse_cell(j, rows_) + 0.5) * c);
      const Eigen::Vector2d moved = v.observed_at(centre, length_s);
      const Eigen::Vector2d d = moved.allFinite() ? Eigen::Vector2d((moved - centre) / c) : Eigen::Vector2d::Zero();
      coarse_.at<cv::Vec2f>(j, i) = cv::Vec2f(static_cast<float>(d.x()), static_cast<float>(d.y()));
    }
  const auto between = [&](int cell, int cells, int& k, float& f) {
    k = std::min(cell / kCoarseStep, (cells - 1) / kCoarseStep);
    const int lo = coarse_cell(k, cells), hi = coarse_cell(k + 1, cells);
    f = hi > lo ? static_cast<float>(cell - lo) / static_cast<float>(hi - lo) : 0.f;
  };
  for (int y = 0; y < rows_; ++y) {
    int ky;
    float fy;
    between(y, rows_, ky, fy);
    for (int x = 0; x < cols_; ++x) {
      int kx;
      float fx;
      between(x, cols_, kx, fx);
      const cv::Vec2f d = (1 - fy) * ((1 - fx) * coarse_.at<cv::Vec2f>(ky, kx) + fx * coarse_.at<cv::Vec2f>(ky, kx + 1)) +
                          fy * ((1 - fx) * coarse_.at<cv::Vec2f>(ky + 1, kx) + fx * coarse_.at<cv::Vec2f>(ky + 1, kx + 1));
      // Where the next window's cell (x, y) was in this window: first order in the flow.
      previous_.at<cv::Vec2f>(y, x) = cv::Vec2f(static_cast<float>(x) - d[0], static_cast<float>(y) - d[1]);
    }
  }
}

bool EvidenceSource::isolated(int x, int y) const {
  // The excess of the 3 × 3 cells around (x, y) and of the ring at Chebyshev distance 2-3 (the
  // 7 × 7 cells less those 3 × 3), clipped at the grid.
  const cv::Mat& e = grid_.excess();
  float centre = 0, surround = 0;
  for (int j = std::max(y - 3, 0); j <= std::min(y + 3, rows_ - 1); ++j)
    for (int i = std::max(x - 3, 0); i <= std::min(x + 3, cols_ - 1); ++i)
      (std::abs(i - x) <= 1 && std::abs(j - y) <= 1 ? centre : surround) += e.at<float>(j, i);
  return surround <= options_.evidence.max_surround_ratio * centre;
}

std::optional<Candidate> EvidenceSource::candidate_at(const SourceWindow& in, cv::Point cell, double evidence) const {
  // The object's events: the cell and half a cell around it (it may straddle cells).
  const EvidenceSourceOptions& o = options_.evidence;
  const int c = o.cell_px;
  const cv::Rect region = cv::Rect(cell.x * c - c / 2, cell.y * c - c / 2, 2 * c, 2 * c) & cv::Rect(0, 0, width_, height_);
  const cv::Mat& I = in.ti.count;
  const cv::Mat& T = in.ti.sum_time_s;
  double events = 0, sx = 0, sy = 0, st = 0;
  for (int y = region.y; y < region.y + region.height; ++y)
    for (int x = region.x; x < region.x + region.width; ++x) {
      const int n = I.at<std::int32_t>(y, x);
      if (n == 0) continue;
      events += n;
      sx += n * (x + 0.5);
      sy += n * (y + 0.5);
      st += T.at<float>(y, x);
    }
  if (events < options_.roi_min_events) return std::nullopt;
  Candidate found;
  found.center = {sx / events, sy / events};
  const double half = 0.5 * c;
  found.box = Box2D{found.center.x() - half, found.center.y() - half, found.center.x() + half, found.center.y() + half};
  found.source = DetectionSource::kEvidence;
  found.events = static_cast<int>(events);
  found.score = evidence / (evidence + o.threshold);
  found.event_density = events / (static_cast<double>(c) * c);
  found.t_mean_s = st / events;
  return found;
}

double EvidenceSource::isolation_of(const SourceWindow& in, const Candidate& found) const {
  const cv::Rect box = box_pixels(found.box, width_, height_);
  if (box.area() == 0) return 0;
  const double image_density = in.window_events() / (static_cast<double>(width_) * height_);
  return isolation(in.ti.count, box, cv::sum(in.ti.count(box))[0], image_density);
}

void EvidenceSource::state_images(std::vector<SourceStateImage>& out) const {
  if (grid_.windows() == 0) return;
  out.insert(out.end(), {{"fired", &fired_},
                         {"mean", &grid_.mean()},
                         {"variance", &grid_.variance()},
                         {"llr", &grid_.llr()},
                         {"evidence", &grid_.evidence()},
                         {"excess", &grid_.excess()},
                         {"travel", &grid_.travel()}});
}

std::optional<Candidate> EvidenceSource::find(SourceWindow& in, DetectionResult& res) {
  if (!in.events.new_evidence) return std::nullopt;
  if (!updated_ || in.events.t_start != last_start_ || in.events.t_end != last_end_) begin_window(in);
  const EvidenceSourceOptions& o = options_.evidence;
  const cv::Mat& L = grid_.evidence();
  // The best path that has travelled over the scene and stands alone, over the grid and in this
  // window's image: the static scene's paths (texture that a hovering camera sweeps, a person's
  // slow sway, forward flight's parallax) hop about their place or run on into their surround.
  double best = 0;
  cv::Point cell(-1, -1);
  std::optional<Candidate> found;
  double found_isolation = 0;
  const float min_travel2 = static_cast<float>(o.min_travel_cells * o.min_travel_cells);
  // Not in the two outermost rings of cells: content entering the view (and the compensation's
  // worst part) is there; a ball entering is found by the other sources once it is in.
  for (int y = kBorderCells; y + kBorderCells < rows_; ++y) {
    const float* Ly = L.ptr<float>(y);
    const cv::Vec2f* travel = grid_.travel().ptr<cv::Vec2f>(y);
    for (int x = kBorderCells; x + kBorderCells < cols_; ++x) {
      if (!(Ly[x] > best) || travel[x].dot(travel[x]) < min_travel2 || !isolated(x, y)) continue;
      if (Ly[x] < o.threshold) {  // no candidate (none found yet: best < h); the diagnostics' path
        best = Ly[x], cell = {x, y};
        continue;
      }
      std::optional<Candidate> c = candidate_at(in, {x, y}, Ly[x]);
      if (!c) continue;
      const double iso = isolation_of(in, *c);
      if (o.min_isolation > 0 && !(iso >= o.min_isolation)) continue;
      best = Ly[x], cell = {x, y}, found = c, found_isolation = iso;
    }
  }
  EvidenceDiagnostics& diag = res.diagnostics_of(kName).write<EvidenceDiagnostics>();
  diag.evidence = best;
  diag.cell_x = cell.x;
  diag.cell_y = cell.y;
  diag.isolation = found_isolation;
  return found;
}

}  // namespace fdv
