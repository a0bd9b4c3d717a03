#pragma once
/// Plain reference of build_time_images() (time_images.h), for tests and benchmarks only: fresh
/// images every call, one loop over the events, one loop over the pixels, scalar arithmetic in
/// the order time_images.h defines. The optimised builder must give the same images, counts and
/// min/max T; mean_normalized may differ in the last bits (its Σ T is summed in another order).
///
///   TimeImages ref;
///   reference_time_images(view, ref);
#include "fdv/detection/time_images.h"

namespace fdv {

void reference_time_images(const CompensatedEventsView& view, TimeImages& out);

}  // namespace fdv
