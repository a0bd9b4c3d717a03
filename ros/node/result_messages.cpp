// Compiled as C++17: see result_messages.h.
#include "result_messages.h"

#include <limits>

namespace fdv::ros_node {
namespace {

using nlohmann::json;

/// ros::Time aborts the process on a time it cannot hold: NodeCore takes no stamp near its end,
/// and this keeps a result's time within it whatever the row says.
ros::Time stamp(const json& seconds) {
  const double s = seconds.get<double>();
  if (!(s > 0)) return ros::Time();
  return s < static_cast<double>(std::numeric_limits<std::uint32_t>::max()) ? ros::Time(s) : ros::TIME_MAX;
}

/// A message header: the row's time in `frame`.
std_msgs::Header header(const json& seconds, const std::string& frame) {
  std_msgs::Header h;
  h.stamp = stamp(seconds);
  h.frame_id = frame;
  return h;
}

double number(const json& j) {  // JSON null is an infinite sigma (results/schema.h)
  return j.is_null() ? std::numeric_limits<double>::infinity() : j.get<double>();
}

template <std::size_t N>
void fill(boost::array<double, N>& out, const json& values) {
  for (std::size_t i = 0; i < N; ++i) out[i] = values.at(i).get<double>();
}

geometry_msgs::Point point(const json& v) {
  geometry_msgs::Point p;
  p.x = v.at(0), p.y = v.at(1), p.z = v.at(2);
  return p;
}

geometry_msgs::Vector3 vector3(const json& v) {
  geometry_msgs::Vector3 p;
  p.x = v.at(0), p.y = v.at(1), p.z = v.at(2);
  return p;
}

}  // namespace

fdv_msgs::WindowDetections window_message(const ros_core::WindowOutput& w, const std::string& frame) {
  const json& r = w.window;
  fdv_msgs::WindowDetections m;
  m.header = header(r.at("t_end"), frame);
  m.index = w.index;
  m.t_start = stamp(r.at("t_start"));
  m.t_end = stamp(r.at("t_end"));
  m.events = r.at("events");
  m.method = r.at("method");
  m.method_requested = r.value("method_requested", "");
  m.status = r.at("status");
  for (const json& d : r.at("detections")) {
    fdv_msgs::Detection o;
    o.t = stamp(d.at("t"));
    fill(o.box, d.at("box"));
    fill(o.center, d.at("center"));
    fill(o.box_undistorted, d.at("box_undistorted"));
    fill(o.center_undistorted, d.at("center_undistorted"));
    o.events = d.at("events");
    o.score = d.at("score");
    o.event_density = d.at("event_density");
    o.track_aided = d.at("track_aided");
    o.source = d.at("source");
    o.track = d.at("track");
    o.partial = d.at("partial");
    o.visible_fraction = d.at("visible_fraction");
    o.has_center_full = d.contains("center_full");
    if (o.has_center_full) fill(o.center_full, d.at("center_full"));
    m.detections.push_back(o);
  }
  m.processing_ms = w.processing_ms;
  m.latency_ms = w.latency_ms;
  return m;
}

fdv_msgs::TrackStates tracks_message(const ros_core::WindowOutput& w, const std::string& frame) {
  fdv_msgs::TrackStates m;
  m.header = header(w.window.at("t_end"), frame);
  for (const json& t : w.tracks) {
    fdv_msgs::TrackState s;
    s.id = t.at("id");
    s.confirmed = t.at("confirmed");
    s.first_t = stamp(t.at("first_t"));
    s.last_update_t = stamp(t.at("last_update_t"));
    s.hits = t.at("hits");
    s.misses = t.at("misses");
    fill(s.center, t.at("center"));
    fill(s.velocity, t.at("velocity"));
    fill(s.center_covariance, t.at("center_covariance"));
    fill(s.box_size, t.at("box_size"));
    m.tracks.push_back(s);
  }
  return m;
}

fdv_msgs::TrajectoryEstimate estimate_message(const json& r, const std::string& frame) {
  fdv_msgs::TrajectoryEstimate m;
  m.header = header(r.at("t"), frame);
  m.track = r.at("track");
  m.method = r.at("method");
  m.fit = r.at("fit");
  m.usable = r.at("usable");
  m.converged = r.at("converged");
  m.t0 = stamp(r.at("t0"));
  m.p0 = point(r.at("p0"));
  m.v0 = vector3(r.at("v0"));
  m.gravity = vector3(r.at("gravity"));
  m.t_first = stamp(r.at("t_first"));
  m.t_last = stamp(r.at("t_last"));
  m.event_observations = r.at("event_observations");
  m.depth_observations = r.at("depth_observations");
  m.outliers = r.at("outliers");
  m.cost = r.at("cost");
  m.iterations = r.at("iterations");
  m.message = r.at("message");
  m.has_covariance = r.contains("covariance");
  if (m.has_covariance) {
    fill(m.covariance, r.at("covariance"));
    m.position_sigma = number(r.at("position_sigma"));
    m.horizon_sigma = number(r.at("horizon_sigma"));
  } else {
    m.position_sigma = m.horizon_sigma = std::numeric_limits<double>::infinity();
  }
  return m;
}

nav_msgs::Path path_message(const json& r, const std::string& frame) {
  nav_msgs::Path m;
  m.header = header(r.at("t"), frame);
  for (const json& p : r.at("path")) {
    geometry_msgs::PoseStamped pose;
    pose.header.stamp = stamp(p.at(0));
    pose.header.frame_id = frame;
    pose.pose.position.x = p.at(1), pose.pose.position.y = p.at(2), pose.pose.position.z = p.at(3);
    pose.pose.orientation.w = 1;
    m.poses.push_back(pose);
  }
  return m;
}

visualization_msgs::MarkerArray markers_message(const nav_msgs::Path& path, int track, double lifetime_s) {
  visualization_msgs::MarkerArray a;
  if (path.poses.empty()) return a;
  visualization_msgs::Marker ball;
  ball.header = path.header;
  ball.ns = "fdv_ball";
  ball.id = track;
  ball.type = visualization_msgs::Marker::SPHERE;
  ball.action = visualization_msgs::Marker::ADD;
  ball.pose = path.poses.front().pose;
  ball.scale.x = ball.scale.y = ball.scale.z = 0.15;
  ball.color.r = 1, ball.color.g = 0.4f, ball.color.a = 1;
  ball.lifetime = ros::Duration(lifetime_s);
  visualization_msgs::Marker line = ball;
  line.ns = "fdv_predicted_path";
  line.type = visualization_msgs::Marker::LINE_STRIP;
  line.pose = geometry_msgs::Pose();
  line.pose.orientation.w = 1;
  line.scale.x = 0.02;
  line.color.r = 0.2f, line.color.g = 0.6f, line.color.b = 1, line.color.a = 1;
  for (const auto& p : path.poses) line.points.push_back(p.pose.position);
  a.markers = {ball, line};
  return a;
}

fdv_msgs::CollisionPrediction prediction_message(const json& r, const std::string& frame) {
  fdv_msgs::CollisionPrediction m;
  m.header = header(r.at("t"), frame);
  m.track = r.at("track");
  m.closest_t = stamp(r.at("closest_t"));
  m.closest_in = r.at("closest_in_s");
  m.miss_distance = r.at("miss_distance");
  m.miss_distance_sigma = r.contains("miss_distance_sigma") ? r.at("miss_distance_sigma").get<double>()
                                                            : std::numeric_limits<double>::quiet_NaN();
  m.object = point(r.at("object_W"));
  m.passage = vector3(r.at("passage_B"));
  m.receding = r.at("receding");
  m.enters_safety_sphere = r.contains("time_to_contact");
  m.time_to_contact = m.enters_safety_sphere ? r.at("time_to_contact").get<double>()
                                             : std::numeric_limits<double>::infinity();
  return m;
}

fdv_msgs::DodgeDecision dodge_message(const json& r, const std::string& frame) {
  fdv_msgs::DodgeDecision m;
  m.header = header(r.at("t"), frame);
  m.effective_t = stamp(r.at("effective_t"));
  m.track = r.at("track");
  m.action = r.at("action");
  m.probability = r.at("probability");
  m.enters_safety_sphere = r.contains("time_to_contact");
  m.time_to_contact = m.enters_safety_sphere ? r.at("time_to_contact").get<double>()
                                             : std::numeric_limits<double>::infinity();
  m.miss_distance = r.at("miss_distance");
  m.committed = r.at("committed");
  m.reason = r.at("reason");
  m.has_maneuver = r.contains("maneuver");
  if (m.has_maneuver) {
    const json& x = r.at("maneuver");
    m.acceleration = vector3(x.at("acceleration_W"));
    m.maneuver_start = stamp(x.at("start_t"));
    m.maneuver_duration = x.at("duration");
    m.expected_clearance = x.at("expected_clearance");
    m.probability_after = x.at("probability_after");
  }
  return m;
}

}  // namespace fdv::ros_node
