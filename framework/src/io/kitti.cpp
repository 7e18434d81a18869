#include "terramrf/io/kitti.hpp"

#include <Eigen/QR>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "fs_checks.hpp"
#include "terramrf/errors.hpp"
#include "terramrf/io/natural_order.hpp"
#include "text_numbers.hpp"

namespace terramrf {
namespace fs = std::filesystem;
namespace {

struct FileCloser {
  void operator()(std::FILE* f) const {
    if (f) std::fclose(f);
  }
};
using FilePtr = std::unique_ptr<std::FILE, FileCloser>;

/// Opens `path` and returns its size [bytes]; InputError naming it on failure.
FilePtr openForRead(const std::string& path, const char* what, std::size_t& bytes) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw InputError(path, std::string(what) + " does not exist");
  bytes = static_cast<std::size_t>(fs::file_size(path, ec));
  if (ec) throw InputError(path, std::string("cannot read ") + what + ": " + ec.message());
  FilePtr f(std::fopen(path.c_str(), "rb"));
  if (!f) throw InputError(path, std::string("cannot open ") + what + ": " + std::strerror(errno));
  return f;
}

void readExactly(std::FILE* f, void* dst, std::size_t bytes, const std::string& path) {
  if (bytes && std::fread(dst, 1, bytes, f) != bytes)
    throw InputError(path, "short read (file truncated while reading?)");
}

std::string fmtSize(std::size_t bytes) { return std::to_string(bytes) + " bytes"; }

Eigen::Isometry3d isoFrom34(const std::vector<double>& v) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) T.linear()(r, c) = v[r * 4 + c];
    T.translation()(r) = v[r * 4 + 3];
  }
  return T;
}

/// Stems of the `ext` files of `dir` in natural order (9 before 10; names need no zero padding).
std::vector<std::string> sortedStems(const fs::path& dir, const std::string& ext) {
  std::vector<std::string> stems;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.is_regular_file() && e.path().extension() == ext)
      stems.push_back(e.path().stem().string());
  sortNatural(stems);
  return stems;
}

/// The last name of `p` as given ("…/sequences/00/" and "." name their folder too).
std::string folderName(const fs::path& p) {
  std::error_code ec;
  fs::path abs = fs::absolute(p, ec).lexically_normal();
  if (ec) abs = p.lexically_normal();
  if (abs.filename().empty()) abs = abs.parent_path();
  return abs.filename().string();
}

/// Whether `sequence` names the sequence folder `name`: the same text, or the same number ("0"
/// and "00", as under sequences/).
bool namesSequence(const std::string& sequence, const std::string& name) {
  if (sequence == name) return true;
  auto digits = [](const std::string& s) {
    return !s.empty() &&
           std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c); });
  };
  if (!digits(sequence) || !digits(name)) return false;
  auto value = [](const std::string& s) {
    const std::size_t first = s.find_first_not_of('0');
    return first == std::string::npos ? std::string("0") : s.substr(first);
  };
  return value(sequence) == value(name);
}

using io_detail::finiteNumber;
using io_detail::isDir;
using io_detail::isFile;
using io_detail::kRotationTolerance;
using io_detail::rotationError;

}  // namespace

ScanReadInfo readKittiScan(const std::string& bin_path, PointCloud& cloud, bool drop_no_return) {
  std::size_t bytes = 0;
  FilePtr f = openForRead(bin_path, "scan file", bytes);
  if (bytes % 16 != 0) {
    throw InputError(bin_path, "size " + fmtSize(bytes) +
                                   " is not a multiple of 16; expected float32 x, y, z, intensity "
                                   "per point (KITTI .bin)");
  }
  ScanReadInfo info;
  info.raw_points = bytes / 16;
  const std::size_t n = info.raw_points;
  cloud.clear();
  cloud.x.resize(n);
  cloud.y.resize(n);
  cloud.z.resize(n);
  cloud.intensity.resize(n);

  // Read in chunks through a reused buffer: one pass over memory, no per-point allocation.
  constexpr std::size_t kChunk = 1 << 15;  // points
  thread_local std::vector<float> buf;
  buf.resize(kChunk * 4);
  std::size_t kept = 0;
  float* X = cloud.x.data();
  float* Y = cloud.y.data();
  float* Z = cloud.z.data();
  float* I = cloud.intensity.data();
  for (std::size_t start = 0; start < n; start += kChunk) {
    const std::size_t m = std::min(kChunk, n - start);
    readExactly(f.get(), buf.data(), m * 16, bin_path);
    const float* const chunk = buf.data();
    auto keepOrDrop = [&](std::size_t j) {
      const float* b = chunk + 4 * j;
      const float x = b[0], y = b[1], z = b[2], in = b[3];
      const bool finite =
          std::isfinite(x) && std::isfinite(y) && std::isfinite(z) && std::isfinite(in);
      const bool origin = x == 0.f && y == 0.f && z == 0.f;
      if (!finite || (drop_no_return && origin)) [[unlikely]] {
        info.dropped.push_back(static_cast<uint32_t>(start + j));
        if (!finite)
          ++info.dropped_nonfinite;
        else
          ++info.dropped_no_return;
        return;
      }
      X[kept] = x;
      Y[kept] = y;
      Z[kept] = z;
      I[kept] = in;
      ++kept;
    };
    std::size_t j = 0;
#if defined(__SSE2__)
    // Four points (a 4 × 4 block of floats) at a time: when all are finite and none is at the
    // origin, one transpose turns them into four x, four y, four z and four intensities. Other
    // blocks go point by point, so what is kept and dropped is unchanged.
    const __m128 zero = _mm_setzero_ps();
    for (; j + 4 <= m; j += 4) {
      const float* b = chunk + 4 * j;
      __m128 p0 = _mm_loadu_ps(b), p1 = _mm_loadu_ps(b + 4);
      __m128 p2 = _mm_loadu_ps(b + 8), p3 = _mm_loadu_ps(b + 12);
      // v - v is 0 for finite v and NaN for ±inf or NaN; summing the four keeps any NaN.
      const __m128 nan_test = _mm_add_ps(_mm_add_ps(_mm_sub_ps(p0, p0), _mm_sub_ps(p1, p1)),
                                         _mm_add_ps(_mm_sub_ps(p2, p2), _mm_sub_ps(p3, p3)));
      const bool all_finite = _mm_movemask_ps(_mm_cmpeq_ps(nan_test, zero)) == 0xF;
      _MM_TRANSPOSE4_PS(p0, p1, p2, p3);  // now x, y, z, intensity of the four points
      const int at_origin = _mm_movemask_ps(_mm_and_ps(
          _mm_and_ps(_mm_cmpeq_ps(p0, zero), _mm_cmpeq_ps(p1, zero)), _mm_cmpeq_ps(p2, zero)));
      if (!all_finite || (drop_no_return && at_origin)) [[unlikely]] {
        for (std::size_t k = j; k < j + 4; ++k) keepOrDrop(k);
        continue;
      }
      _mm_storeu_ps(X + kept, p0);
      _mm_storeu_ps(Y + kept, p1);
      _mm_storeu_ps(Z + kept, p2);
      _mm_storeu_ps(I + kept, p3);
      kept += 4;
    }
#endif
    for (; j < m; ++j) keepOrDrop(j);
  }
  cloud.x.resize(kept);
  cloud.y.resize(kept);
  cloud.z.resize(kept);
  cloud.intensity.resize(kept);
  return info;
}

void readKittiLabels(const std::string& label_path, const std::string& scan_path,
                     const ScanReadInfo& info, const LabelMap* map, PointLabels& truth) {
  std::size_t bytes = 0;
  FilePtr f = openForRead(label_path, "label file", bytes);
  if (bytes % 4 != 0) {
    throw InputError(label_path, "size " + fmtSize(bytes) +
                                     " is not a multiple of 4; expected one uint32 per point");
  }
  const std::size_t count = bytes / 4;
  if (count != info.raw_points) {
    throw InputError(label_path, "has " + std::to_string(count) + " labels but the scan " +
                                     scan_path + " has " + std::to_string(info.raw_points) +
                                     " points; expected one label per point");
  }
  truth.raw.resize(count);
  readExactly(f.get(), truth.raw.data(), bytes, label_path);
  eraseIndices(truth.raw, info.dropped);
  for (auto& r : truth.raw) r &= 0xFFFFu;  // semantic class; the high half is the instance
  if (map)
    map->mapAll(truth.raw, truth.label, label_path);
  else
    truth.label.clear();
}

void readKittiRings(const std::string& ring_path, const std::string& scan_path,
                    const ScanReadInfo& info, PointCloud& cloud) {
  std::size_t bytes = 0;
  FilePtr f = openForRead(ring_path, "ring file", bytes);
  if (bytes % 2 != 0 || bytes / 2 != info.raw_points) {
    throw InputError(ring_path, "has " + fmtSize(bytes) + " (" + std::to_string(bytes / 2) +
                                    " rings) but the scan " + scan_path + " has " +
                                    std::to_string(info.raw_points) +
                                    " points; expected one uint16 per point");
  }
  cloud.ring.resize(info.raw_points);
  readExactly(f.get(), cloud.ring.data(), bytes, ring_path);
  eraseIndices(cloud.ring, info.dropped);
}

KittiCalib readKittiCalib(const std::string& path) {
  std::ifstream in(path);
  if (!isFile(path) || !in)
    throw InputError(path, "calibration file does not exist or cannot be read");
  KittiCalib c;
  c.path = path;
  std::string line;
  int lineno = 0;
  while (std::getline(in, line)) {
    ++lineno;
    const auto colon = line.find(':');
    if (colon == std::string::npos) {
      if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
      throw InputError(path, "line " + std::to_string(lineno) + ": expected 'KEY: numbers'");
    }
    std::string key = line.substr(0, colon);
    key.erase(std::remove_if(key.begin(), key.end(), ::isspace), key.end());
    std::istringstream ss(line.substr(colon + 1));
    std::vector<double> v;
    std::string tok;
    while (ss >> tok) {
      const std::optional<double> x = finiteNumber(tok);
      // Raw KITTI calib files carry a "calib_time: <date>" line: an entry that does not start
      // with a number is not a matrix. One that does must be numbers throughout.
      if (!x && v.empty()) break;
      if (!x)
        throw InputError(path, "line " + std::to_string(lineno) + ": '" + key + ":' value '" + tok +
                                   "' is not a finite number");
      v.push_back(*x);
    }
    if (!v.empty()) c.entries[key] = std::move(v);
  }
  auto need = [&](const std::string& key, std::size_t n) -> const std::vector<double>& {
    auto it = c.entries.find(key);
    if (it == c.entries.end()) throw InputError(path, "no '" + key + ":' entry");
    if (it->second.size() != n)
      throw InputError(path, "'" + key + ":' has " + std::to_string(it->second.size()) +
                                 " numbers; expected " + std::to_string(n));
    return it->second;
  };
  // Only what is read is required: the LiDAR→camera transform below, and the P of each camera a
  // source reads, which kittiCamera asks for. Own data often has just P2 and Tr, and KITTI's
  // P0..P3 all being there is no reason to refuse it; an entry that is there must be whole.
  for (int i = 0; i < 4; ++i) {
    const std::string key = "P" + std::to_string(i);
    c.P[i].setZero();
    c.has_P[i] = c.entries.count(key) > 0;
    if (!c.has_P[i]) continue;
    const auto& v = need(key, 12);
    for (int r = 0; r < 3; ++r)
      for (int col = 0; col < 4; ++col) c.P[i](r, col) = v[r * 4 + col];
  }
  // A transform whose 3×3 is no rotation (a digit lost in an edit) would shear the scan into
  // the image and pass unnoticed until the colours look wrong.
  auto rotation = [&](const std::string& key, const Eigen::Matrix3d& R) {
    const double err = rotationError(R);
    if (err > kRotationTolerance)
      throw InputError(path, "'" + key + ":' rotation part is not a rotation (|R·Rᵀ − I| = " +
                                 std::to_string(err) + ", or a reflection)");
  };
  if (c.entries.count("Tr_velo_to_cam")) {
    c.object_format = true;
    const Eigen::Isometry3d velo_to_cam = isoFrom34(need("Tr_velo_to_cam", 12));
    rotation("Tr_velo_to_cam", velo_to_cam.linear());
    Eigen::Isometry3d rect = Eigen::Isometry3d::Identity();
    const auto& r0 = need("R0_rect", 9);
    for (int r = 0; r < 3; ++r)
      for (int col = 0; col < 3; ++col) rect.linear()(r, col) = r0[r * 3 + col];
    rotation("R0_rect", rect.linear());
    c.T_cam_velo = rect * velo_to_cam;
  } else if (c.entries.count("Tr")) {
    c.T_cam_velo = isoFrom34(need("Tr", 12));
    rotation("Tr", c.T_cam_velo.linear());
  } else {
    throw InputError(path,
                     "no LiDAR->camera transform: expected 'Tr:' (odometry) or "
                     "'R0_rect:' + 'Tr_velo_to_cam:' (object)");
  }
  return c;
}

namespace {

/// P = K · [R | t] with K upper triangular (positive diagonal, K(2,2) = 1) and R a rotation
/// (RQ decomposition of P's left 3×3 through a QR of its flipped transpose). False when the left
/// 3×3 is singular: no camera centre, not a projection.
bool decomposeProjection(const Matrix34d& P_in, Eigen::Matrix3d& K, Eigen::Isometry3d& T) {
  Matrix34d P = P_in;
  if (P.leftCols<3>().determinant() < 0) P = -P;  // P and −P project alike
  const Eigen::Matrix3d M = P.leftCols<3>();
  if (!(std::abs(M.determinant()) > 1e-12 * std::pow(M.norm(), 3))) return false;
  Eigen::Matrix3d J = Eigen::Matrix3d::Zero();
  J(0, 2) = J(1, 1) = J(2, 0) = 1;
  const Eigen::HouseholderQR<Eigen::Matrix3d> qr((J * M).transpose());
  const Eigen::Matrix3d Q = qr.householderQ();
  const Eigen::Matrix3d Rt = qr.matrixQR().triangularView<Eigen::Upper>();
  K = J * Rt.transpose() * J;
  Eigen::Matrix3d R = J * Q.transpose();
  const Eigen::Vector3d sign = K.diagonal().array().sign();
  K = K * sign.asDiagonal();  // D·D = I: K·D · D·R = K·R
  R = sign.asDiagonal() * R;
  T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = K.inverse() * P.col(3);
  K /= K(2, 2);
  return true;
}

}  // namespace

CameraModel kittiCamera(const KittiCalib& calib, int index, int width_px, int height_px) {
  if (index < 0 || index > 3 || !calib.has_P[index])
    throw InputError(calib.path, "no 'P" + std::to_string(index) + ":' entry; camera image_" +
                                     std::to_string(index) + " needs it (its 3x4 projection)");
  CameraModel m;
  m.name = "image_" + std::to_string(index);
  m.width = width_px;
  m.height = height_px;
  m.P = calib.P[index];
  m.T_camera_lidar = calib.T_cam_velo;
  m.calibration = (calib.path.empty() ? std::string("KITTI calibration") : calib.path) + " (P" +
                  std::to_string(index) +
                  (calib.object_format ? ", R0_rect, Tr_velo_to_cam)" : ", Tr)");
  // KITTI's own cameras differ from camera 0 by a translation only, and P keeps it in its last
  // column. A P that also turns the camera (a rig written by `terramrf simulate` with a camera
  // looking sideways or back) has its rotation moved into T_camera_lidar, so that depth
  // (front/behind, occlusion tests) is measured along that camera's own axis.
  Eigen::Matrix3d K;
  Eigen::Isometry3d T_cam_cam0;
  if (!decomposeProjection(m.P, K, T_cam_cam0))
    throw InputError(calib.path, "P" + std::to_string(index) +
                                     " is not a camera projection (its left 3×3 is singular)");
  if (!T_cam_cam0.linear().isIdentity(1e-9)) {
    m.P.setZero();
    m.P.leftCols<3>() = K;
    m.T_camera_lidar = T_cam_cam0 * calib.T_cam_velo;
  }
  return m;
}

std::vector<Eigen::Isometry3d> readKittiPoses(const std::string& path) {
  std::ifstream in(path);
  if (!isFile(path) || !in) throw InputError(path, "poses file does not exist or cannot be read");
  std::vector<Eigen::Isometry3d> poses;
  std::string line;
  int lineno = 0;
  std::vector<double> v;
  while (std::getline(in, line)) {
    ++lineno;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::istringstream ss(line);
    v.clear();
    std::string tok;
    while (ss >> tok) {
      const std::optional<double> x = finiteNumber(tok);
      if (!x)
        throw InputError(path, "line " + std::to_string(lineno) + ": '" + tok +
                                   "' is not a finite number (expected 12, a row-major 3x4 pose)");
      v.push_back(*x);
    }
    if (v.size() != 12) {
      throw InputError(path, "line " + std::to_string(lineno) +
                                 ": expected 12 numbers (row-major 3x4 pose), got " +
                                 std::to_string(v.size()));
    }
    poses.push_back(isoFrom34(v));
    const double err = rotationError(poses.back().linear());
    if (err > kRotationTolerance)
      throw InputError(path, "line " + std::to_string(lineno) +
                                 ": the pose's 3x3 is not a rotation (|R·Rᵀ − I| = " +
                                 std::to_string(err) + ", or a reflection)");
  }
  return poses;
}

Eigen::Isometry3d kittiLidarPose(const Eigen::Isometry3d& cam0_pose, const Eigen::Isometry3d& Tr) {
  return Tr.inverse() * cam0_pose * Tr;
}

std::vector<double> readKittiTimes(const std::string& path) {
  std::ifstream in(path);
  if (!isFile(path) || !in) throw InputError(path, "times file does not exist or cannot be read");
  std::vector<double> t;
  std::string line;
  int lineno = 0;
  while (std::getline(in, line)) {
    ++lineno;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::istringstream ss(line);
    std::string tok, extra;
    ss >> tok >> extra;
    const std::optional<double> x = finiteNumber(tok);
    if (!x || !extra.empty())
      throw InputError(
          path, "line " + std::to_string(lineno) + ": expected one time [s], got '" + line + "'");
    t.push_back(*x);
  }
  return t;
}

std::string KittiLayout::scanPath(std::size_t i) const {
  return (fs::path(root) / "velodyne" / (stems.at(i) + ".bin")).string();
}
std::string KittiLayout::labelPath(std::size_t i) const {
  return (fs::path(root) / "labels" / (stems.at(i) + ".label")).string();
}
std::string KittiLayout::imagePath(std::size_t i, const std::string& camera) const {
  return (fs::path(root) / camera / (stems.at(i) + ".png")).string();
}
std::string KittiLayout::ringPath(std::size_t i) const {
  return (fs::path(root) / "rings" / (stems.at(i) + ".bin")).string();
}
std::string KittiLayout::calibPath(std::size_t i) const {
  if (kind == Kind::kObject) return (fs::path(root) / "calib" / (stems.at(i) + ".txt")).string();
  return calib_file;
}

KittiLayout resolveKittiLayout(const std::string& path, const std::string& sequence) {
  fs::path p(path);
  if (!isDir(p)) throw ParamError("path", "'" + path + "' is not a folder");
  fs::path folder;
  fs::path dataset_root;  // for <root>/poses/NN.txt of the original odometry layout
  std::string seq_name;
  if (isDir(p / "velodyne")) {
    folder = p;
  } else if (isDir(p / "sequences")) {
    std::vector<std::string> seqs;
    for (const auto& e : fs::directory_iterator(p / "sequences"))
      if (e.is_directory()) seqs.push_back(e.path().filename().string());
    sortNatural(seqs);
    std::string list;
    for (const auto& s : seqs) list += (list.empty() ? "" : ", ") + s;
    if (sequence.empty()) {
      // An empty sequences/ folder is not "several sequences ()".
      if (seqs.empty())
        throw ParamError("path", "'" + path +
                                     "' has an empty sequences/ folder; expected "
                                     "sequences/NN/velodyne/");
      if (seqs.size() != 1)
        throw ParamError("sequence", "'" + path + "' holds several sequences (" + list +
                                         "); set 'sequence' to one of them");
      seq_name = seqs[0];
    } else {
      seq_name = sequence;
      if (!isDir(p / "sequences" / seq_name)) {
        // The same number names the same sequence ("0" for "00"), as for a sequence folder below.
        const auto it = std::find_if(seqs.begin(), seqs.end(), [&](const std::string& s) {
          return namesSequence(sequence, s);
        });
        if (it == seqs.end())
          throw ParamError("sequence", "no sequences/" + sequence + " under '" + path +
                                           "' (available: " + list + ")");
        seq_name = *it;
      }
    }
    folder = p / "sequences" / seq_name;
    dataset_root = p;
    if (!isDir(folder / "velodyne"))
      throw ParamError("path", "'" + folder.string() + "' has no velodyne/ folder");
  } else if (isDir(p / "training" / "velodyne")) {
    folder = p / "training";
  } else {
    throw ParamError("path", "'" + path +
                                 "' is not a KITTI folder: expected velodyne/ (a sequence or an "
                                 "object 'training' folder), sequences/NN/velodyne/, or training/");
  }
  KittiLayout L;
  L.root = folder.string();
  L.kind = isDir(folder / "calib") ? KittiLayout::Kind::kObject : KittiLayout::Kind::kSequence;
  // `sequence` picks a folder under sequences/. A path that is a sequence or object folder itself
  // has nothing to pick, and reading it for another sequence would label the results with the
  // wrong one. The parameter defaults to "", so a value here was set on purpose.
  if (!sequence.empty() && dataset_root.empty()) {
    if (L.kind == KittiLayout::Kind::kObject)
      throw ParamError("sequence", "is '" + sequence + "', but path '" + path +
                                       "' is a KITTI object folder, which has no sequences; "
                                       "leave sequence empty");
    const std::string name = folderName(p);
    if (!namesSequence(sequence, name))
      throw ParamError("sequence", "is '" + sequence + "', but path '" + path +
                                       "' is itself the sequence folder '" + name +
                                       "' (it holds velodyne/); give the dataset root (the folder "
                                       "holding sequences/) as path to choose a sequence, or "
                                       "leave sequence empty");
  }
  L.stems = sortedStems(folder / "velodyne", ".bin");
  if (L.kind == KittiLayout::Kind::kSequence) {
    L.calib_file = (folder / "calib.txt").string();
    if (isFile(folder / "poses.txt"))
      L.poses_file = (folder / "poses.txt").string();
    else if (!dataset_root.empty() && isFile(dataset_root / "poses" / (seq_name + ".txt")))
      L.poses_file = (dataset_root / "poses" / (seq_name + ".txt")).string();
    if (isFile(folder / "times.txt")) L.times_file = (folder / "times.txt").string();
  }
  return L;
}

}  // namespace terramrf
