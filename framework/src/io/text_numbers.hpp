#pragma once
// Internal to the dataset readers: numbers in the text files of datasets (calibration, poses,
// times), read strictly. std::stod reads "1.5abc" as 1.5 and "nan" as NaN, and a NaN in a
// calibration or a pose passes every later range check (comparisons with NaN are false).
#include <Eigen/Geometry>
#include <cmath>
#include <cstdlib>
#include <optional>
#include <string>

namespace terramrf::io_detail {

/// `tok` as a finite double; nothing if any of it is not part of the number, or it is NaN/inf.
inline std::optional<double> finiteNumber(const std::string& tok) {
  if (tok.empty()) return std::nullopt;
  char* end = nullptr;
  const double v = std::strtod(tok.c_str(), &end);
  if (end != tok.c_str() + tok.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

/// How far `R` is from a rotation: max |R Rᵀ − I| (0 for a rotation), or 1 when det(R) < 0.
/// KITTI prints calibrations and poses with 7–13 significant digits, so theirs are ~1e-7 off.
inline double rotationError(const Eigen::Matrix3d& R) {
  if (R.determinant() < 0) return 1.0;
  return (R * R.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
}

/// Largest rotationError a rigid transform read from a file may have.
constexpr double kRotationTolerance = 1e-3;

}  // namespace terramrf::io_detail
