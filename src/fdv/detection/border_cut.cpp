#include "fdv/detection/border_cut.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace fdv {
namespace {

/// The disc's centre offset c from the border (positive: inside) whose visible part, the segment
/// of depth R + c, has its centroid `centroid` from the border: c + g(R + c) rises monotonically
/// from 0 (c = −R) to R (c = R), so bisection finds it.
double center_offset(double centroid, double radius) {
  if (centroid >= radius) return centroid;  // the whole disc in view: its centroid is its centre
  double lo = -radius, hi = radius;
  for (int i = 0; i < 60; ++i) {
    const double c = 0.5 * (lo + hi);
    (c + disc_segment_centroid(radius + c, radius) < centroid ? lo : hi) = c;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

double disc_segment_fraction(double depth, double radius) {
  const double h = std::clamp(depth, 0.0, 2 * radius), d = radius - h;
  const double area = radius * radius * std::acos(d / radius) - d * std::sqrt(std::max(0.0, 2 * radius * h - h * h));
  return area / (std::numbers::pi * radius * radius);
}

double disc_segment_centroid(double depth, double radius) {
  // θ: the central angle of the chord; the segment's centroid lies 4R sin³(θ/2) / (3(θ − sin θ))
  // from the centre.
  const double h = std::clamp(depth, 1e-9 * radius, 2 * radius);
  const double theta = 2 * std::acos(std::clamp((radius - h) / radius, -1.0, 1.0));
  const double s = std::sin(0.5 * theta);
  return 4 * radius * s * s * s / (3 * (theta - std::sin(theta)));
}

std::optional<BorderCut> border_cut(const Box2D& square, int width, int height) {
  const double lo = -0.5, hi_x = width - 0.5, hi_y = height - 0.5;
  const double side = std::max(square.width(), square.height());
  const double margin = std::max(1.0, 0.05 * side);
  const bool left = square.x0 <= lo + margin, right = square.x1 >= hi_x - margin;
  const bool top = square.y0 <= lo + margin, bottom = square.y1 >= hi_y - margin;
  if (!left && !right && !top && !bottom) return std::nullopt;
  BorderCut cut;
  cut.visible = {std::max(square.x0, lo), std::max(square.y0, lo), std::min(square.x1, hi_x), std::min(square.y1, hi_y)};
  const double radius = 0.5 * side;
  if (!(radius > 0)) return cut;
  const Eigen::Vector2d centroid = square.center();
  // Per cut axis: the centroid's distance from that border, and the disc's centre offset from it.
  auto offset_x = [&] { return center_offset(left ? centroid.x() - lo : hi_x - centroid.x(), radius); };
  auto offset_y = [&] { return center_offset(top ? centroid.y() - lo : hi_y - centroid.y(), radius); };
  const bool cut_x = left || right, cut_y = top || bottom;
  if (cut_x && cut_y) {  // a corner: the two cuts taken as independent
    cut.visible_fraction =
        disc_segment_fraction(radius + offset_x(), radius) * disc_segment_fraction(radius + offset_y(), radius);
    return cut;
  }
  const double c = cut_x ? offset_x() : offset_y();
  cut.visible_fraction = disc_segment_fraction(radius + c, radius);
  cut.center_full = cut_x ? Eigen::Vector2d(left ? lo + c : hi_x - c, centroid.y())
                          : Eigen::Vector2d(centroid.x(), top ? lo + c : hi_y - c);
  return cut;
}

}  // namespace fdv
