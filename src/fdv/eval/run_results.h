#pragma once
/// Reading back a `fdv run` results folder (README "Commands") for evaluation: the windows'
/// detections (detections.jsonl) and the converged trajectory estimates (trajectories.jsonl).
/// Throws InputError naming the file and line for a malformed line.
#include <string>
#include <vector>

#include "fdv/eval/detection_metrics.h"
#include "fdv/eval/estimate_metrics.h"

namespace fdv {

/// RESULTS/detections.jsonl, one entry per window. Throws InputError when the file is missing.
std::vector<WindowDetections> read_detections(const std::string& results_dir);

/// The converged estimates (usable flagged) of RESULTS/trajectories.jsonl in file order (empty when the file is
/// absent: a run without 3D estimation).
std::vector<EstimateRecord> read_estimates(const std::string& results_dir);

}  // namespace fdv
