#pragma once
/// Absolute position error (APE) of an estimated object trajectory against ground truth, as in
/// the paper's Table II: the Euclidean distance between estimated and true positions at every
/// ground-truth sample inside [t_begin, t_end], summarised by mean, min, max and RMSE. Positions
/// are compared in the world frame directly (no alignment: the estimate is metric and in W).
#include <functional>
#include <vector>

#include "fdv/core/sensor_data.h"
#include "fdv/eval/statistics.h"

namespace fdv {

using PositionFunction = std::function<Eigen::Vector3d(TimeNs)>;

/// The error at each truth sample of object `id` with t in [t_begin, t_end] (in time order), for
/// pooling the samples of several runs before summarising them.
std::vector<double> position_errors(const PositionFunction& estimate,
                                    const std::vector<ObjectState>& truth, int id, TimeNs t_begin,
                                    TimeNs t_end);

/// summarize(position_errors(...)); count 0 if there are no truth samples in the interval.
Summary absolute_position_error(const PositionFunction& estimate,
                                const std::vector<ObjectState>& truth, int id, TimeNs t_begin,
                                TimeNs t_end);

}  // namespace fdv
