#include "terramrf/lcm/scan_messages.hpp"

#include <algorithm>
#include <cmath>

#include "terramrf/errors.hpp"
#include "terramrf/lcm/labels_codec.hpp"
#include "terramrf/lcm/pose_codec.hpp"
#include "terramrf/lcm/sensor_codec.hpp"

namespace terramrf {

void dropUnusablePoints(Frame& f, bool drop_no_return) {
  PointCloud& c = f.points;
  const bool labelled = !f.truth.label.empty(), raw = !f.truth.raw.empty();
  const bool rings = c.hasRing(), times = !c.time_s.empty();
  std::size_t kept = 0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    if (!std::isfinite(c.x[i]) || !std::isfinite(c.y[i]) || !std::isfinite(c.z[i]) ||
        !std::isfinite(c.intensity[i])) {
      ++f.dropped_nonfinite_points;
      continue;
    }
    if (drop_no_return && c.x[i] == 0 && c.y[i] == 0 && c.z[i] == 0) {
      ++f.dropped_no_return_points;
      continue;
    }
    c.x[kept] = c.x[i];
    c.y[kept] = c.y[i];
    c.z[kept] = c.z[i];
    c.intensity[kept] = c.intensity[i];
    if (rings) c.ring[kept] = c.ring[i];
    if (times) c.time_s[kept] = c.time_s[i];
    if (labelled) f.truth.label[kept] = f.truth.label[i];
    if (raw) f.truth.raw[kept] = f.truth.raw[i];
    ++kept;
  }
  if (kept == c.size()) return;
  c.x.resize(kept);
  c.y.resize(kept);
  c.z.resize(kept);
  c.intensity.resize(kept);
  if (rings) c.ring.resize(kept);
  if (times) c.time_s.resize(kept);
  if (labelled) f.truth.label.resize(kept);
  if (raw) f.truth.raw.resize(kept);
}

Frame frameFromMessages(const ScanMessages& m, const ScanOptions& o) {
  static const LabelSet kDefaults = LabelSet::defaults();
  const LabelSet& labels = o.labels ? *o.labels : kDefaults;
  Frame f;
  f.id = m.id;
  f.source_path = o.source_path;
  {
    const ScanMessage& p = m.points;
    DecodedPointCloud cloud = decodePointCloud(p.bytes.data(), p.bytes.size(), p.source);
    if (cloud.header.coordinate_frame != "lidar") {
      throw InputError(p.source, "point cloud in frame '" + cloud.header.coordinate_frame +
                                     "'; expected \"lidar\" (x forward, y left, z up): the "
                                     "grid is centred on the sensor");
    }
    f.timestamp_s = cloud.header.timestamp_s;
    f.points = std::move(cloud.cloud);
  }
  if (m.labels) {
    const ScanMessage& l = *m.labels;
    f.truth = mapPointLabels(decodePointLabels(l.bytes.data(), l.bytes.size(), l.source), labels,
                             l.source);
    if (f.truth.label.size() != f.points.size()) {
      throw InputError(l.source, "point_labels_t has " + std::to_string(f.truth.label.size()) +
                                     " labels for the " + std::to_string(f.points.size()) +
                                     " points of scan '" + f.id +
                                     "'; expected one per point, in the cloud's order");
    }
  }
  if (m.pose) {
    const ScanMessage& p = *m.pose;
    setFramePose(f, decodePose(p.bytes.data(), p.bytes.size(), p.source), p.source);
  } else if (!o.pose_channel.empty()) {
    throw InputError(m.points.source, "no pose_t on channel " + o.pose_channel + " for scan '" +
                                          f.id +
                                          "'; a pose channel is read, so every scan needs its "
                                          "pose");
  }
  if (m.truth_pose) {
    const ScanMessage& t = *m.truth_pose;
    const PoseMessage p = decodePose(t.bytes.data(), t.bytes.size(), t.source);
    if (p.child_frame != "lidar")
      throw InputError(t.source, "ground-truth pose of '" + p.child_frame +
                                     "'; expected the LiDAR's (child_frame \"lidar\")");
    f.truth_pose = p.pose;
  }
  dropUnusablePoints(f, o.drop_no_return);
  for (const ScanMessage& s : m.imu)
    f.imu.push_back(decodeImu(s.bytes.data(), s.bytes.size(), s.source));
  for (const ScanMessage& s : m.gps)
    f.gps.push_back(decodeGps(s.bytes.data(), s.bytes.size(), s.source));
  for (const ScanMessage& s : m.odometry)
    f.odometry.push_back(decodeOdometry(s.bytes.data(), s.bytes.size(), s.source));
  // In time order, as the other sources give them, whatever order the publishers' messages came
  // in.
  const auto byTime = [](const auto& a, const auto& b) { return a.t_s < b.t_s; };
  std::stable_sort(f.imu.begin(), f.imu.end(), byTime);
  std::stable_sort(f.gps.begin(), f.gps.end(), byTime);
  std::stable_sort(f.odometry.begin(), f.odometry.end(), byTime);
  return f;
}

}  // namespace terramrf
