// Source plugin "pointcloud_file": PCD and PLY clouds through PCL, one file or a folder of them.
// Optional per-point fields "intensity", "ring" and "label" are used when present.
#include <pcl/PCLPointCloud2.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "terramrf/io/label_map.hpp"
#include "terramrf/io/natural_order.hpp"
#include "terramrf/io/ring_recovery.hpp"
#include "terramrf/io/sensor_origin.hpp"
#include "terramrf/params.hpp"
#include "terramrf/plugin.hpp"

namespace terramrf {
namespace {
namespace fs = std::filesystem;

std::string lowerExt(const fs::path& p) {
  std::string e = p.extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
  return e;
}

/// Reads field `f` of point `i` as double, whatever its stored type.
double fieldValue(const pcl::PCLPointCloud2& c, const pcl::PCLPointField& f, std::size_t i) {
  const std::size_t row = i / c.width, col = i % c.width;
  const uint8_t* p = c.data.data() + row * c.row_step + col * c.point_step + f.offset;
  auto get = [p](auto tag) {
    decltype(tag) v;
    std::memcpy(&v, p, sizeof v);
    return double(v);
  };
  switch (f.datatype) {
    case pcl::PCLPointField::INT8:
      return get(int8_t{});
    case pcl::PCLPointField::UINT8:
      return get(uint8_t{});
    case pcl::PCLPointField::INT16:
      return get(int16_t{});
    case pcl::PCLPointField::UINT16:
      return get(uint16_t{});
    case pcl::PCLPointField::INT32:
      return get(int32_t{});
    case pcl::PCLPointField::UINT32:
      return get(uint32_t{});
    case pcl::PCLPointField::FLOAT32:
      return get(float{});
    case pcl::PCLPointField::FLOAT64:
      return get(double{});
    default:
      return std::nan("");
  }
}

/// VIEWPOINT tx ty tz qw qx qy qz of a PCD header: the sensor's pose in the file's frame (PCL: the
/// acquisition viewpoint, sensor origin + orientation; default 0 0 0 1 0 0 0). Points in the
/// sensor frame are p_s = Rᵀ (p − t).
struct PcdViewpoint {
  Eigen::Vector3d t = Eigen::Vector3d::Zero();  ///< sensor position in the file's frame [m]
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  std::string text = "0 0 0 1 0 0 0";  ///< as written, for messages
  /// What the written digits of t leave uncertain, when that is metres far from the origin
  /// (writtenPrecisionNote); "" when t is written precisely enough.
  std::string precision_note;
  bool identity() const { return t.isZero(0) && q.w() == 1 && q.vec().isZero(0); }
  /// The sensor's pose in the file's frame, T_file_sensor.
  Eigen::Isometry3d pose() const {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = q.toRotationMatrix();
    T.translation() = t;
    return T;
  }
};

/// Significant digits of a decimal number as written and the place value of its last digit
/// ("5.81235e+06": 6 and 10; "512346": 6 and 1; "0.00120": 3 and 1e-5). False if `tok` is not
/// plain decimal text.
bool writtenDigits(const std::string& tok, int& digits, double& last_place) {
  std::size_t k = (!tok.empty() && (tok[0] == '-' || tok[0] == '+')) ? 1 : 0;
  std::string mantissa_digits;
  int decimals = 0;
  bool point = false;
  for (; k < tok.size() && tok[k] != 'e' && tok[k] != 'E'; ++k) {
    if (tok[k] == '.' && !point) {
      point = true;
    } else if (std::isdigit(static_cast<unsigned char>(tok[k]))) {
      mantissa_digits += tok[k];
      decimals += point ? 1 : 0;
    } else {
      return false;
    }
  }
  long exponent = 0;
  if (k < tok.size()) {
    char* end = nullptr;
    exponent = std::strtol(tok.c_str() + k + 1, &end, 10);
    if (k + 1 == tok.size() || *end != 0) return false;
  }
  const std::size_t first = mantissa_digits.find_first_not_of('0');
  digits = first == std::string::npos ? 0 : int(mantissa_digits.size() - first);
  last_place = std::pow(10.0, double(exponent - decimals));
  return !mantissa_digits.empty();
}

/// PCL writes VIEWPOINT through a stream at its default 6 significant digits (pcd_io.hpp), so a
/// UTM northing 5812345.68 comes back as 5.81235e+06, 4.3 m off, and every point moved into the
/// sensor frame with it. A coordinate beyond 1e5 m written with 6 digits or fewer is named with
/// what it may be off by (half its last digit's place); "" when none is.
std::string writtenPrecisionNote(const std::vector<std::string>& tok, const Eigen::Vector3d& t) {
  constexpr double kFarM = 1e5;  // from here on 6 digits leave ≥ 0.5 m uncertain
  std::string note;
  for (int i = 0; i < 3; ++i) {
    int digits = 0;
    double place = 0;
    if (std::abs(t[i]) <= kFarM || !writtenDigits(tok[i], digits, place) || digits > 6) continue;
    note += std::string(note.empty() ? "" : ", ") + "t" + "xyz"[i] + " " + tok[i] + " only to ±" +
            numberText(place / 2) + " m";
  }
  return note;
}

/// Reads the VIEWPOINT tokens into `vp`; what is wrong with them, or "". PCL reads it with
/// stream extraction, so a NaN, a missing number or a zero quaternion went through.
std::string readViewpoint(const std::vector<std::string>& tok, PcdViewpoint& vp) {
  std::string text;
  for (const auto& t : tok) text += (text.empty() ? "" : " ") + t;
  std::vector<double> v;
  for (const auto& t : tok) {
    char* end = nullptr;
    const double x = std::strtod(t.c_str(), &end);
    if (t.empty() || *end != 0 || !std::isfinite(x)) break;
    v.push_back(x);
  }
  if (tok.size() != 7 || v.size() != 7)
    return "VIEWPOINT must be 7 numbers, tx ty tz qw qx qy qz (the sensor's pose in the file's "
           "frame), got '" +
           text + "'";
  const Eigen::Quaterniond q(v[3], v[4], v[5], v[6]);
  // PCL writes 6 significant digits: a unit quaternion comes back within ~1e-6 of norm 1.
  if (std::abs(q.norm() - 1) > 1e-3) {
    std::ostringstream o;
    o << "VIEWPOINT quaternion (qw qx qy qz) " << v[3] << ' ' << v[4] << ' ' << v[5] << ' ' << v[6]
      << " has norm " << q.norm() << "; expected 1 (a rotation)";
    return o.str();
  }
  vp.t = Eigen::Vector3d(v[0], v[1], v[2]);
  vp.q = q.normalized();
  vp.text = text;
  vp.precision_note = writtenPrecisionNote(tok, vp.t);
  return "";
}

/// What is wrong with a PCD header, or "" (then PCL reads the file). PCL 1.13 trusts its header:
/// COUNT -1 crashed it (SIGSEGV), "DATA" without a type came back as vector::_M_range_check,
/// and readHeader allocates and zero-fills the declared POINTS before reading any data, so a
/// damaged 99 999 999 cost 2 GB and 9 s to end in "cannot read" with no reason (all found by
/// fuzzing). Checked here: one SIZE (1, 2, 4, 8), TYPE (I, U, F) and COUNT (≥ 1) per field;
/// WIDTH × HEIGHT = POINTS; a DATA kind; and a body big enough for POINTS — SIZE × COUNT bytes a
/// point in binary, two characters ("0 ") a value in ASCII. Compressed bodies carry their own
/// sizes, which PCL checks.
using PcdHeaderKeys = std::map<std::string, std::vector<std::string>>;

/// The header lines of a PCD, key → tokens, up to DATA or the 64th line; `in` is left at the body.
PcdHeaderKeys readPcdHeaderKeys(std::istream& in) {
  std::string line;
  PcdHeaderKeys keys;
  for (int k = 0; k < 64 && std::getline(in, line); ++k) {
    std::istringstream ss(line);
    std::string key, tok;
    if (!(ss >> key) || key[0] == '#') continue;
    auto& v = keys[key];
    while (ss >> tok) v.push_back(tok);
    if (key == "DATA") break;
  }
  return keys;
}

/// Whether a PCD's header has a VIEWPOINT that reads as a pose other than the identity. A header
/// that cannot be read counts as none: reading the frame says what is wrong with it.
bool hasMovedViewpoint(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  const PcdHeaderKeys keys = readPcdHeaderKeys(in);
  const auto it = keys.find("VIEWPOINT");
  PcdViewpoint vp;
  return it != keys.end() && readViewpoint(it->second, vp).empty() && !vp.identity();
}

std::string pcdHeaderProblem(const std::string& file, PcdViewpoint& viewpoint) {
  std::ifstream in(file, std::ios::binary);
  PcdHeaderKeys keys = readPcdHeaderKeys(in);
  auto count = [](const std::string& tok, unsigned long long& out) {
    if (tok.empty() || tok[0] == '-' || tok[0] == '+') return false;
    char* end = nullptr;
    errno = 0;
    out = std::strtoull(tok.c_str(), &end, 10);
    return *end == 0 && errno == 0 && out < (1ULL << 32);
  };
  auto one = [&](const char* key, unsigned long long& out) -> std::string {
    const auto it = keys.find(key);
    if (it == keys.end() || it->second.size() != 1 || !count(it->second[0], out))
      return std::string(key) + " must be one whole number below 2^32";
    return "";
  };
  if (const auto vp = keys.find("VIEWPOINT"); vp != keys.end())
    if (std::string why = readViewpoint(vp->second, viewpoint); !why.empty()) return why;
  const auto data_it = keys.find("DATA");
  if (data_it == keys.end())  // not a PCD header at all (PCL says so), or one cut short
    return keys.count("FIELDS") ? "no DATA line (ascii, binary or binary_compressed) in the "
                                  "first 64 lines: the header is cut short"
                                : "";
  if (data_it->second.size() != 1 ||
      (data_it->second[0] != "ascii" && data_it->second[0] != "binary" &&
       data_it->second[0] != "binary_compressed"))
    return "DATA must be ascii, binary or binary_compressed";
  const std::vector<std::string>& fields = keys["FIELDS"];
  if (fields.empty()) return "";  // PCL's "no x, y, z fields" check below words it
  const std::size_t n = fields.size();
  const auto& sizes = keys["SIZE"];
  const auto& types = keys["TYPE"];
  std::vector<std::string> counts = keys["COUNT"];
  if (counts.empty()) counts.assign(n, "1");
  if (sizes.size() != n || types.size() != n || counts.size() != n)
    return std::to_string(n) + " FIELDS need as many SIZE, TYPE and COUNT entries (got " +
           std::to_string(sizes.size()) + ", " + std::to_string(types.size()) + ", " +
           std::to_string(counts.size()) + ")";
  unsigned long long step = 0, values = 0;
  for (std::size_t f = 0; f < n; ++f) {
    unsigned long long size = 0, c = 0;
    if (!count(sizes[f], size) || (size != 1 && size != 2 && size != 4 && size != 8))
      return "SIZE of field '" + fields[f] + "' is '" + sizes[f] + "'; expected 1, 2, 4 or 8";
    if (types[f] != "I" && types[f] != "U" && types[f] != "F")
      return "TYPE of field '" + fields[f] + "' is '" + types[f] + "'; expected I, U or F";
    if (!count(counts[f], c) || c < 1 || c > 65536)
      return "COUNT of field '" + fields[f] + "' is '" + counts[f] + "'; expected 1 to 65536";
    step += size * c;
    values += c;
  }
  unsigned long long width = 0, height = 0, points = 0;
  for (const auto& [key, out] : {std::pair<const char*, unsigned long long*>{"WIDTH", &width},
                                 {"HEIGHT", &height},
                                 {"POINTS", &points}})
    if (std::string why = one(key, *out); !why.empty()) return why;
  if (width * height != points)  // each < 2^32: no overflow
    return "WIDTH " + std::to_string(width) + " x HEIGHT " + std::to_string(height) +
           " is not POINTS " + std::to_string(points);
  if (data_it->second[0] == "binary_compressed") return "";
  const auto at = in.tellg();
  std::error_code ec;
  const auto size = fs::file_size(file, ec);
  if (ec || at < 0) return "";
  const unsigned long long body = size > std::size_t(at) ? size - std::size_t(at) : 0;
  const bool binary = data_it->second[0] == "binary";
  const unsigned long long per_point = std::max(1ULL, binary ? step : values * 2);
  const unsigned long long most = body / per_point;  // a division: points * per_point overflows
  if (points <= most) return "";
  return "the header declares POINTS " + std::to_string(points) + ", but " + std::to_string(body) +
         " bytes of " + (binary ? "binary" : "ASCII") + " data hold at most " +
         std::to_string(most);
}

const pcl::PCLPointField* findField(const pcl::PCLPointCloud2& c, const std::string& name) {
  for (const auto& f : c.fields)
    if (f.name == name) return &f;
  return nullptr;
}

class PointCloudFileSource : public Source {
 public:
  void declare(ParamDecl& d) override {
    d.add("path", path_,
          "a .pcd or .ply file, or a folder of them (frames in natural name order: 9 before 10)")
        .required()
        .existingPath();
    d.add("label_map", label_map_,
          "label-map YAML for a per-point 'label' field (empty: the field holds project class ids)")
        .existingPath();
    d.add("use_labels", use_labels_, "read a per-point 'label' field when the file has one");
    d.add("drop_no_return", drop_no_return_, "drop points exactly at (0, 0, 0) (counted)");
    d.add("ring_method", ring_method_,
          "when the file has no 'ring' field: none (leave rings empty), auto (scan order, else "
          "elevation binning) or elevation")
        .choices({"none", "auto", "elevation"});
    d.add("rings", rings_, "lasers of the sensor, for ring recovery").unit("1").range(1, 1024);
    d.add("ring_z_offset_m", ring_z_offset_m_, "laser origin above the cloud origin")
        .unit("m")
        .range(-5, 5);
    d.add("recentre", recentre_,
          "none, or auto: estimate the sensor origin from the innermost ground ring and move the "
          "cloud (and its pose) so the sensor is at (0, 0), for a scan stored shifted from its "
          "sensor without a VIEWPOINT (a PLY, or a PCD of a map crop); applied after a "
          "VIEWPOINT. Not for clouds at UTM-sized coordinates: stored as float they have lost "
          "their detail before any shift (give such a PCD its VIEWPOINT)")
        .choices({"none", "auto"});
    d.add("recentre_min_m", recentre_min_m_,
          "auto recentring only applies shifts longer than this (the estimate is good to ~0.3 m)")
        .unit("m")
        .range(0, 1000);
  }

  void configure(const PluginContext& ctx) override {
    files_.clear();
    const fs::path p(path_);
    auto usable = [](const fs::path& f) {
      const std::string e = lowerExt(f);
      return e == ".pcd" || e == ".ply";
    };
    if (fs::is_directory(p)) {
      for (const auto& e : fs::directory_iterator(p))
        if (e.is_regular_file() && usable(e.path())) files_.push_back(e.path().string());
      sortNatural(files_);  // scan9 before scan10, as recorded
      if (files_.empty()) throw ParamError("path", "no .pcd or .ply files in '" + path_ + "'");
    } else {
      if (!usable(p)) throw ParamError("path", "'" + path_ + "' is not a .pcd or .ply file");
      files_.push_back(p.string());
    }
    labels_ = ctx.labels ? *ctx.labels : LabelSet::defaults();
    map_.reset();
    if (use_labels_ && !label_map_.empty()) {
      try {
        map_ = std::make_unique<LabelMap>(LabelMap::load(label_map_, labels_));
      } catch (const InputError& e) {
        throw ParamError("label_map", e.what());
      }
    }
    ring_options_.rings = rings_;
    ring_options_.use_scan_order = ring_method_ == "auto";
    ring_options_.z_offset_m = ring_z_offset_m_;
    ring_options_.measure_consistency = false;  // the rings are all a reader needs
    told_viewpoint_ = told_precision_ = false;
    // Decided for the whole source before its first frame, so that every frame of a map saved
    // per scan has a pose, the one whose VIEWPOINT is the map's origin included: a frame without
    // one among frames with one is refused by outputs that keep a trajectory. Only the headers
    // are read (≤ 64 lines each).
    poses_from_viewpoints_ = false;
    for (const auto& file : files_)
      if (lowerExt(file) == ".pcd" && hasMovedViewpoint(file)) {
        poses_from_viewpoints_ = true;
        break;
      }
  }

  /// A pose for every frame only when its PCDs give them (a moved VIEWPOINT in any) and it has
  /// no PLY, which never has one: a pose for some frames only is not declared, as stages that
  /// read the pose rely on having it for every frame.
  std::vector<std::string> writes() const override {
    for (const auto& file : files_)
      if (lowerExt(file) == ".ply") return {};
    return poses_from_viewpoints_ ? std::vector<std::string>{artefacts::kPose}
                                  : std::vector<std::string>{};
  }

  std::size_t size() const override { return files_.size(); }
  std::string frameId(std::size_t i) const override {
    return fs::path(files_.at(i)).stem().string();
  }

  Frame read(std::size_t i) override {
    if (i >= size())
      throw std::out_of_range("pointcloud_file: frame " + std::to_string(i) + " of " +
                              std::to_string(size()));
    const std::string& file = files_[i];
    pcl::PCLPointCloud2 c2;
    int rc = -1;
    std::string why;
    const bool ply = lowerExt(file) == ".ply";
    PcdViewpoint viewpoint;
    if (!ply)
      if (const std::string problem = pcdHeaderProblem(file, viewpoint); !problem.empty())
        throw InputError(file, "bad PCD header: " + problem);
    try {
      if (ply) {
        rc = pcl::io::loadPLYFile(file, c2);
      } else {
        // PCL 1.13 crashes reading the body of a header without fields: check the header first.
        pcl::PCDReader reader;
        Eigen::Vector4f origin;
        Eigen::Quaternionf orientation;
        int version = 0, data_type = 0;
        unsigned int data_index = 0;
        rc = reader.readHeader(file, c2, origin, orientation, version, data_type, data_index);
        if (rc >= 0 && !(findField(c2, "x") && findField(c2, "y") && findField(c2, "z"))) {
          rc = -1;
          why = "the header lists no x, y, z fields";
        } else if (rc >= 0 && std::size_t(c2.width) * c2.height > 0) {
          rc = reader.read(file, c2);
        }
      }
    } catch (const std::exception& e) {
      why = e.what();
    }
    if (rc < 0) {
      throw InputError(file, "PCL cannot read it as " + std::string(ply ? "PLY" : "PCD") +
                                 (why.empty() ? " (PCL printed its reason above, on stderr)"
                                              : " (" + why + ")") +
                                 "; expected a point cloud with x, y, z fields");
    }
    const auto* f_x = findField(c2, "x");
    const auto* f_y = findField(c2, "y");
    const auto* f_z = findField(c2, "z");
    if (!f_x || !f_y || !f_z) {
      std::string names;
      for (const auto& fld : c2.fields) names += (names.empty() ? "" : ", ") + fld.name;
      throw InputError(file, "has no x, y, z fields (it has: " + names +
                                 "); expected a point cloud with x, y, z fields");
    }
    const std::size_t n = std::size_t(c2.width) * c2.height;
    const std::size_t needed = (c2.height ? std::size_t(c2.height - 1) * c2.row_step : 0) +
                               std::size_t(c2.width) * c2.point_step;
    if (c2.data.size() < needed)
      throw InputError(
          file, "point data shorter than its header says: " + std::to_string(c2.data.size()) +
                    " bytes, expected " + std::to_string(needed) + " for " +
                    std::to_string(c2.width) + " x " + std::to_string(c2.height) + " points");

    const auto* f_int = findField(c2, "intensity");
    const auto* f_ring = findField(c2, "ring");
    const auto* f_label = use_labels_ ? findField(c2, "label") : nullptr;

    Frame f;
    f.id = frameId(i);
    f.source_path = file;
    f.points.reserve(n);
    if (f_ring) f.points.ring.clear();
    std::size_t nonfinite = 0, origin = 0;
    auto refuse = [&](std::size_t k, const char* field, double v, const char* expected) {
      std::ostringstream o;  // %g-like: 2.5, -1, 1e+10 rather than 2.500000
      o << "point " << k << " has " << field << ' ' << v << "; expected " << expected;
      throw InputError(file, o.str());
    };
    // The VIEWPOINT is applied in double, before a point is stored in single precision: at a
    // UTM northing (~5.8e6 m) floats are 0.5 m apart, so points stored first and moved after
    // kept their offsets from the sensor only to 0.5 m (flat ground read as rough).
    const bool move = !viewpoint.identity();
    const Eigen::Matrix3d Rt = viewpoint.q.toRotationMatrix().transpose();
    for (std::size_t k = 0; k < n; ++k) {
      // Every field is read by its stored type. PCL's fromPCLPointCloud2 left x, y, z and
      // intensity at 0 when they were not float32 (only a "Failed to find match" warning), so a
      // cloud of float64 coordinates read as points at the origin, dropped as no-returns.
      Eigen::Vector3d p(fieldValue(c2, *f_x, k), fieldValue(c2, *f_y, k), fieldValue(c2, *f_z, k));
      const float in = f_int ? float(fieldValue(c2, *f_int, k)) : 0.f;
      if (!p.allFinite() || !std::isfinite(in)) {
        ++nonfinite;
        continue;
      }
      // A no-return is the (0, 0, 0) the file stores, whatever the viewpoint.
      if (drop_no_return_ && p.isZero(0)) {
        ++origin;
        continue;
      }
      if (move) p = Rt * (p - viewpoint.t);  // p_s = Rᵀ (p − t), into the sensor frame
      const float x = float(p.x()), y = float(p.y()), z = float(p.z());
      if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) {  // beyond float's range
        ++nonfinite;
        continue;
      }
      f.points.x.push_back(x);
      f.points.y.push_back(y);
      f.points.z.push_back(z);
      f.points.intensity.push_back(in);
      if (f_ring) {
        // Negative or out-of-range rings mean "not known" (drivers write -1); a fraction is
        // neither a laser index nor that, so it is refused rather than truncated.
        const double r = fieldValue(c2, *f_ring, k);
        if (std::isfinite(r) && r != std::floor(r))
          refuse(k, "ring", r, "a whole laser index (negative = unknown)");
        f.points.ring.push_back(r >= 0 && r < kUnknownRing ? uint16_t(r) : kUnknownRing);
      }
      if (f_label) {
        const double l = fieldValue(c2, *f_label, k);
        if (!(l >= 0 && l <= 4294967295.0 && l == std::floor(l)))
          refuse(k, "label", l, "a non-negative integer id");
        f.truth.raw.push_back(uint32_t(l));
      }
    }
    f.dropped_nonfinite_points = nonfinite;
    f.dropped_no_return_points = origin;
    if (move) tellViewpoint(viewpoint, file);
    // The viewpoint is the sensor's pose in the file's frame: for a folder of scans stored in one
    // map frame, the frame's pose in that map. Set for every PCD of a source in which any file
    // has a viewpoint other than the identity (one at the map's origin included), never for one
    // whose files all have the default: "no pose" then still says so. Not truth_pose: the file
    // records whatever pose its writer had (a SLAM or GNSS/INS estimate as often as a surveyed
    // one), and an egomotion estimate's distance from another estimate is the error of neither.
    if (!ply && poses_from_viewpoints_) f.pose = viewpoint.pose();
    if (f_label) {
      if (map_) {
        map_->mapAll(f.truth.raw, f.truth.label, file);
      } else {
        f.truth.label.resize(f.truth.raw.size());
        for (std::size_t k = 0; k < f.truth.raw.size(); ++k) {
          if (f.truth.raw[k] >= labels_.size())
            throw InputError(file, "label " + std::to_string(f.truth.raw[k]) +
                                       " is not a project class id (0.." +
                                       std::to_string(labels_.size() - 1) +
                                       "); give a label_map for dataset ids");
          f.truth.label[k] = LabelId(f.truth.raw[k]);
        }
      }
    }
    // Before ring recovery, which reads elevations around the sensor.
    if (recentre_ == "auto") recentreOnSensor(f, recentre_min_m_, "pointcloud_file");
    if (!f_ring) {
      f.points.ring.clear();
      if (ring_method_ != "none") recoverRings(f.points, ring_options_);
    }
    if (c2.header.stamp) f.timestamp_s = double(c2.header.stamp) * 1e-6;  // PCL stamps are [us]
    return f;
  }

 private:
  /// Says on stderr, once a source (a folder of one recording shares its viewpoint's form), that
  /// the VIEWPOINT was applied, and when its written digits leave the sensor's position metres
  /// uncertain (PCL's 6 significant digits), by how much.
  void tellViewpoint(const PcdViewpoint& vp, const std::string& file) {
    if (!told_viewpoint_) {
      told_viewpoint_ = true;
      std::fprintf(stderr,
                   "pointcloud_file: %s: VIEWPOINT %s applied: points moved from the file's frame "
                   "into the sensor's (p_s = R^T (p - t))%s\n",
                   file.c_str(), vp.text.c_str(),
                   poses_from_viewpoints_ ? "; the frames' poses are their VIEWPOINTs" : "");
    }
    if (!vp.precision_note.empty() && !told_precision_) {
      told_precision_ = true;
      std::fprintf(stderr,
                   "pointcloud_file: %s: warning: VIEWPOINT %s gives %s (6 or fewer significant "
                   "digits, as PCL writes it): the sensor's position, and every point moved into "
                   "its frame, may be off by as much; write the VIEWPOINT to the millimetre "
                   "(e.g. printf's %%.3f) rather than through PCL's writer\n",
                   file.c_str(), vp.text.c_str(), vp.precision_note.c_str());
    }
  }

  std::string path_;
  std::string label_map_;
  bool use_labels_ = true;
  bool drop_no_return_ = true;
  std::string ring_method_ = "none";
  int rings_ = 64;
  double ring_z_offset_m_ = 0.0;
  std::string recentre_ = "none";
  double recentre_min_m_ = 1.0;

  std::vector<std::string> files_;
  LabelSet labels_;
  std::unique_ptr<LabelMap> map_;
  RingRecoveryOptions ring_options_;
  bool poses_from_viewpoints_ = false;  ///< some file of the source has a moved VIEWPOINT
  bool told_viewpoint_ = false;
  bool told_precision_ = false;
};

}  // namespace
}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::PointCloudFileSource, terramrf::PluginKind::kSource, "pointcloud_file",
                "PCD / PLY point clouds through PCL (a file or a folder); optional intensity, ring "
                "and label fields")
