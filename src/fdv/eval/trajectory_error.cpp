#include "fdv/eval/trajectory_error.h"

namespace fdv {

std::vector<double> position_errors(const PositionFunction& estimate,
                                    const std::vector<ObjectState>& truth, int id, TimeNs t_begin,
                                    TimeNs t_end) {
  std::vector<double> errors;
  for (const ObjectState& s : truth)
    if (s.id == id && s.t >= t_begin && s.t <= t_end)
      errors.push_back((estimate(s.t) - s.p_W).norm());
  return errors;
}

Summary absolute_position_error(const PositionFunction& estimate,
                                const std::vector<ObjectState>& truth, int id, TimeNs t_begin,
                                TimeNs t_end) {
  return summarize(position_errors(estimate, truth, id, t_begin, t_end));
}

}  // namespace fdv
