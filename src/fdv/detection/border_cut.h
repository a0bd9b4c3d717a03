#pragma once
/// How a round object's box meets the sensor's border (docs/DETECTION.md, "Objects cut by the
/// border"): the visible box, the share of the object in view, and the whole object's centre.
///
///   // the reported square: centred on the visible events' centroid, side = the object's diameter
///   if (const auto cut = border_cut(square_raw, 346, 260)) {
///     report(cut->visible, cut->visible_fraction);     // the part in the frame
///     if (cut->center_full) use(*cut->center_full);     // the disc's centre, outside or inside
///   }
/// Thread safety: value types and pure functions; may be used from any thread.
#include <Eigen/Core>
#include <optional>

#include "fdv/detection/detection2d.h"

namespace fdv {

struct BorderCut {
  Box2D visible;                ///< the box clipped to the sensor
  double visible_fraction = 1;  ///< share of the disc's area inside the sensor (estimate)
  /// The disc's centre [raw px], when exactly one border cuts it.
  std::optional<Eigen::Vector2d> center_full;
};

/// Nothing when `square` (raw pixels, pixel centres at integers) keeps clear of the border of a
/// width × height sensor by max(1 px, 5 % of its side). The object is a disc of diameter the
/// square's side whose visible part has its centroid at the square's centre: cut by one border,
/// the disc's centre is where a disc of that radius has its visible part's centroid there; cut by
/// two (a corner), only the visible fraction is estimated, as the two cuts' product.
std::optional<BorderCut> border_cut(const Box2D& square, int width, int height);

/// Area of a disc's segment of depth `depth` ∈ [0, 2R] as a fraction of the disc (radius R > 0).
double disc_segment_fraction(double depth, double radius);

/// Distance from a disc's centre to the centroid of its segment of depth `depth` ∈ (0, 2R], on the
/// segment's side (R for a vanishing segment, 0 for the whole disc).
double disc_segment_centroid(double depth, double radius);

}  // namespace fdv
