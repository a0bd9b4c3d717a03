#include "fdv/detection/candidate_source.h"

#include <algorithm>
#include <mutex>

#include "fdv/core/error.h"
#include "fdv/detection/count_contrast_source.h"
#include "fdv/detection/dense_motion_source.h"
#include "fdv/detection/evidence_source.h"
#include "fdv/detection/gaussian_fit_source.h"
#include "fdv/detection/track_aided_source.h"

namespace fdv {

double isolation(const cv::Mat& count, const cv::Rect& box, double box_events, double floor_density) {
  const cv::Rect surround =
      cv::Rect(box.x - box.width, box.y - box.height, 3 * box.width, 3 * box.height) & cv::Rect(0, 0, count.cols, count.rows);
  const double surround_pixels = static_cast<double>(surround.area() - box.area());
  const double surround_density = surround_pixels > 0 ? (cv::sum(count(surround))[0] - box_events) / surround_pixels : 0;
  return box_events / box.area() / std::max(surround_density, floor_density);
}

namespace {

/// The built-in sources, in the order a Detector tries them (detector.h says why this order): one
/// line each.
std::vector<RegisteredSource> built_in_sources() {
  return {
      {GaussianFitSource::kName, make_source<GaussianFitSource>},
      {TrackAidedSource::kName, make_source<TrackAidedSource>},
      {DenseMotionSource::kName,
       [](const DetectorOptions& o) { return o.dense_motion.enabled ? make_source<DenseMotionSource>(o) : nullptr; }},
      {CountContrastSource::kName,
       [](const DetectorOptions& o) { return o.count_contrast.enabled ? make_source<CountContrastSource>(o) : nullptr; }},
      {EvidenceSource::kName,
       [](const DetectorOptions& o) { return o.evidence.enabled ? make_source<EvidenceSource>(o) : nullptr; }},
  };
}

struct Registry {
  std::mutex mutex;
  std::vector<RegisteredSource> sources = built_in_sources();
  std::size_t built_in = sources.size();
};

Registry& registry() {
  static Registry r;
  return r;
}

}  // namespace

std::vector<RegisteredSource> registered_sources() {
  Registry& r = registry();
  const std::lock_guard lock(r.mutex);
  return r.sources;
}

void register_candidate_source(std::string_view name, CandidateSourceFactory make) {
  const bool word = !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
  });
  if (!word)
    throw ConfigError("candidate source name \"" + std::string(name) + "\": letters, digits and '_' only");
  if (!make) throw ConfigError("candidate source " + std::string(name) + ": no factory");
  Registry& r = registry();
  const std::lock_guard lock(r.mutex);
  if (std::any_of(r.sources.begin(), r.sources.end(), [&](const RegisteredSource& s) { return s.name == name; }))
    throw ConfigError("candidate source " + std::string(name) + " is registered already");
  if (r.sources.size() >= kMaxCandidateSources)
    throw ConfigError("candidate source " + std::string(name) + ": at most " + std::to_string(kMaxCandidateSources) +
                      " sources");
  r.sources.push_back({name, std::move(make)});
}

bool unregister_candidate_source(std::string_view name) {
  Registry& r = registry();
  const std::lock_guard lock(r.mutex);
  const auto added = r.sources.begin() + static_cast<std::ptrdiff_t>(r.built_in);
  const auto it = std::find_if(added, r.sources.end(), [&](const RegisteredSource& s) { return s.name == name; });
  if (it == r.sources.end()) return false;
  r.sources.erase(it);
  return true;
}

}  // namespace fdv
