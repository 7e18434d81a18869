#pragma once
// λ_k of eq. 1 (paper 000): the eigenvalue of a 3 × 3 point covariance whose eigenvector is
// closest to vertical, k = argmax_i |e_iᵀ z|.
//
// Why not a full eigendecomposition: only the z components of the eigenvectors are needed, and
// those follow from the eigenvalues alone (the eigenvector–eigenvalue identity; Denton, Parke,
// Tao, Zhang, Bull. AMS 59, 2022):
//   |e_i,z|² · Π_{j≠i} (λ_i − λ_j) = det(λ_i I − C_xy),
// C_xy the 2 × 2 upper-left block of C. Eigen's computeDirect spends much of its time on the
// eigenvectors; without them the whole stage takes 0.38 instead of 0.48 ms (KITTI object 000000,
// BM_EigenPreclass, median of 10). Where two eigenvalues (nearly) coincide the identity divides by
// ~0 and the eigenvectors are not unique anyway; there the full solver decides, as before. The
// layer is bit-identical to the full solver's on the SemanticKITTI sequence 00 scans.
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

namespace terramrf {

/// Relative eigenvalue gap below which normalEigenvalue asks Eigen for the eigenvectors. The
/// identity's error in |e_i,z|² is about ε · λ_max² / gap² (ε = 2.2e-16): 1e-4 keeps it < 1e-7.
constexpr double kNormalEigenvalueMinGap = 1e-4;

/// The full solver's answer (reference and fallback).
inline double normalEigenvalueBySolver(const Eigen::Matrix3d& C) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(C);
  const Eigen::Matrix3d& E = es.eigenvectors();
  int k = 0;
  double best = -1;
  for (int i = 0; i < 3; ++i) {
    const double a = std::abs(E(2, i));
    if (a > best) best = a, k = i;
  }
  return es.eigenvalues()(k);
}

/// λ_k of the symmetric matrix C (only its lower triangle is read, as by Eigen).
inline double normalEigenvalue(const Eigen::Matrix3d& C) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(C, Eigen::EigenvaluesOnly);
  const Eigen::Vector3d& l = es.eigenvalues();  // ascending
  const double scale = std::max(std::abs(l(0)), std::abs(l(2)));
  const double g01 = l(1) - l(0), g12 = l(2) - l(1);
  if (!(std::min(g01, g12) > kNormalEigenvalueMinGap * scale)) return normalEigenvalueBySolver(C);
  const double cxx = C(0, 0), cyy = C(1, 1), cxy = C(1, 0);
  int k = 0;
  double best = -1;
  for (int i = 0; i < 3; ++i) {
    const double li = l(i);
    const double num = (li - cxx) * (li - cyy) - cxy * cxy;
    const double den = (li - l((i + 1) % 3)) * (li - l((i + 2) % 3));
    const double z2 = num / den;  // |e_i,z|²
    if (z2 > best) best = z2, k = i;
  }
  return l(k);
}

}  // namespace terramrf
