#include "terramrf/io/kitti_writer.hpp"

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <string_view>

#include "terramrf/adapters/opencv_image.hpp"
#include "terramrf/atomic_file.hpp"

namespace terramrf {

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "KittiSequenceWriter writes the host's byte order; KITTI files are little-endian"
#endif

namespace {

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

/// Row-major 3×4 as 12 numbers.
std::string row34(const Eigen::Matrix<double, 3, 4>& M) {
  std::string s;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) s += (s.empty() ? "" : " ") + fmt("%.12e", M(r, c));
  return s;
}

Eigen::Matrix<double, 3, 4> top34(const Eigen::Isometry3d& T) { return T.matrix().topRows<3>(); }

template <class T>
std::string_view bytesOf(const std::vector<T>& v) {
  return {reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T)};
}

bool sameCamera(const CameraModel& a, const CameraModel& b) {
  return a.width == b.width && a.height == b.height && a.P.isApprox(b.P, 1e-12) &&
         a.T_camera_lidar.matrix().isApprox(b.T_camera_lidar.matrix(), 1e-12);
}

}  // namespace

KittiSequenceWriter::KittiSequenceWriter(std::string dir) : dir_(std::move(dir)) {
  std::error_code ec;
  std::filesystem::create_directories(dir_, ec);
  if (ec) throw std::runtime_error("cannot create output folder '" + dir_ + "': " + ec.message());
}

KittiSequenceWriter::~KittiSequenceWriter() {
  if (finished_ || count_ == 0) return;
  try {
    finish();
  } catch (...) {
    // A destructor must not throw; callers who care call finish() themselves.
  }
}

std::string KittiSequenceWriter::stem(std::size_t i) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%06zu", i);
  return buf;
}

void KittiSequenceWriter::write(const Frame& f) {
  if (finished_) throw std::runtime_error("KittiSequenceWriter: write() after finish()");
  const std::string name = "frame '" + f.id + "'";
  const PointCloud& pc = f.points;
  const std::size_t n = pc.size();
  if (pc.y.size() != n || pc.z.size() != n || pc.intensity.size() != n)
    throw std::runtime_error(name + ": point arrays differ in length");
  if (!f.truth.raw.empty() && f.truth.raw.size() != n)
    throw std::runtime_error(name + ": " + std::to_string(f.truth.raw.size()) + " raw labels for " +
                             std::to_string(n) + " points");
  // A dataset's poses.txt is its reference, read back as truth_pose: the truth where the frame
  // has one, never an egomotion estimate in its place.
  const std::optional<Eigen::Isometry3d>& pose = f.truth_pose ? f.truth_pose : f.pose;
  // Pose bookkeeping first so a bad frame leaves nothing behind.
  if (pose ? frames_without_pose_ > 0 : !lidar_poses_.empty())
    throw std::runtime_error(name +
                             (pose ? " has a pose but earlier frames had none"
                                   : " has no pose but earlier frames had one") +
                             "; poses.txt needs one pose per frame");
  if (f.cameras.size() > 2)
    throw std::runtime_error(name + " has " + std::to_string(f.cameras.size()) +
                             " cameras; calib.txt holds two colour cameras (image_2, image_3)");
  // image_2 first: the camera named so, else the first one.
  std::vector<const CameraImage*> cams;
  for (const CameraImage& c : f.cameras) cams.push_back(&c);
  if (cams.size() == 2 && cams[1]->model.name == "image_2") std::swap(cams[0], cams[1]);
  for (const CameraImage* c : cams)
    for (double k : c->model.distortion)
      if (k != 0)
        throw std::runtime_error(name + ": camera '" + c->model.name +
                                 "' has lens distortion, which KITTI's calib.txt cannot hold");
  if (cameras_set_) {
    bool same = cams.size() == cameras_.size();
    for (std::size_t k = 0; same && k < cams.size(); ++k)
      same = sameCamera(cameras_[k], cams[k]->model);
    if (!same)
      throw std::runtime_error(name +
                               ": cameras or their calibration differ from the sequence's first "
                               "frame; calib.txt holds one calibration per sequence");
  }

  const std::string s = stem(count_);
  {
    std::vector<float> buf(4 * n);
    for (std::size_t i = 0; i < n; ++i) {
      buf[4 * i] = pc.x[i];
      buf[4 * i + 1] = pc.y[i];
      buf[4 * i + 2] = pc.z[i];
      buf[4 * i + 3] = pc.intensity[i];
    }
    writeFileAtomic(dir_ + "/velodyne/" + s + ".bin", bytesOf(buf));
  }
  if (!f.truth.raw.empty()) {
    // SemanticKITTI: low 16 bits semantic id, high 16 bits instance (0 here).
    std::vector<uint32_t> lab(n);
    for (std::size_t i = 0; i < n; ++i) lab[i] = f.truth.raw[i] & 0xFFFFu;
    writeFileAtomic(dir_ + "/labels/" + s + ".label", bytesOf(lab));
  }
  if (pc.hasRing()) writeFileAtomic(dir_ + "/rings/" + s + ".bin", bytesOf(pc.ring));
  for (std::size_t k = 0; k < cams.size(); ++k) {
    const std::string folder = "/image_" + std::to_string(2 + k);
    if (cams[k]->image) writeImageAtomic(dir_ + folder + "/" + s + ".png", *cams[k]->image);
    if (cams[k]->truth) writeImageAtomic(dir_ + folder + "_truth/" + s + ".png", *cams[k]->truth);
  }
  if (!cameras_set_) {
    for (const CameraImage* c : cams) cameras_.push_back(c->model);
    cameras_set_ = true;
  }

  times_.push_back(f.timestamp_s);
  if (pose)
    lidar_poses_.push_back(*pose);
  else
    ++frames_without_pose_;
  for (const ImuSample& m : f.imu) {
    imu_ += fmt("%.6f", m.t_s);
    for (int k = 0; k < 3; ++k) imu_ += " " + fmt("%.9e", m.gyro_rad_s[k]);
    for (int k = 0; k < 3; ++k) imu_ += " " + fmt("%.9e", m.accel_m_s2[k]);
    imu_ += "\n";
  }
  for (const GpsSample& g : f.gps) {
    gps_ += fmt("%.6f", g.t_s);
    for (int k = 0; k < 3; ++k) gps_ += " " + fmt("%.6f", g.position_m[k]);
    gps_ += " " + fmt("%.6f", g.sigma_m) + "\n";
  }
  for (const OdometrySample& o : f.odometry)
    odometry_ += fmt("%.6f", o.t_s) + " " + fmt("%.9e", o.speed_m_s) + " " +
                 fmt("%.9e", o.yaw_rate_rad_s) + "\n";
  ++count_;
}

void KittiSequenceWriter::finish() {
  if (finished_) return;
  Eigen::Matrix<double, 3, 4> P = Eigen::Matrix<double, 3, 4>::Zero();
  P.leftCols<3>().setIdentity();
  Eigen::Isometry3d Tr = Eigen::Isometry3d::Identity();
  if (!cameras_.empty()) {
    P = cameras_[0].P;
    Tr = cameras_[0].T_camera_lidar;
  }
  // Odometry-style calib: a reader projecting with P2 · Tr · X gets image_2's own pixels, and
  // with P3 · Tr · X the second camera's (its pose relative to image_2 folded into P3).
  Eigen::Matrix<double, 3, 4> P3 = P;
  if (cameras_.size() > 1)
    P3 = cameras_[1].P * (cameras_[1].T_camera_lidar * Tr.inverse()).matrix();
  std::string calib;
  for (int i = 0; i < 4; ++i)
    calib += "P" + std::to_string(i) + ": " + row34(i == 3 ? P3 : P) + "\n";
  calib += "Tr: " + row34(top34(Tr)) + "\n";
  writeFileAtomic(dir_ + "/calib.txt", calib);

  std::string times;
  for (double t : times_) times += fmt("%.9e", t) + "\n";
  writeFileAtomic(dir_ + "/times.txt", times);

  if (!lidar_poses_.empty()) {
    const Eigen::Isometry3d Tr_inv = Tr.inverse();
    std::string poses;
    for (const Eigen::Isometry3d& T_w_lidar : lidar_poses_)
      poses += row34(top34(Tr * T_w_lidar * Tr_inv)) + "\n";
    writeFileAtomic(dir_ + "/poses.txt", poses);
  }
  writeFileAtomic(dir_ + "/imu.txt",
                  "# t_s gyro_x_rad_s gyro_y_rad_s gyro_z_rad_s accel_x_m_s2 accel_y_m_s2 "
                  "accel_z_m_s2 (body = LiDAR frame: x forward, y left, z up; accel = specific "
                  "force)\n" +
                      imu_);
  writeFileAtomic(dir_ + "/gps.txt",
                  "# t_s x_m y_m z_m sigma_m (world frame, local north-west-up; sigma = 1σ "
                  "horizontal)\n" +
                      gps_);
  writeFileAtomic(
      dir_ + "/odometry.txt",
      "# t_s speed_m_s yaw_rate_rad_s (forward speed, yaw rate about world up)\n" + odometry_);
  finished_ = true;
}

}  // namespace terramrf
