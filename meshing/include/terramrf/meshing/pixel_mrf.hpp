#pragma once
// Binary Gibbs-MRF over the pixels of an image (paper 004 §3.2, eq. 1–12). Sites are pixels with
// 4-neighbours; label 1 is the class seeded by G1 (ground in §3.2, object in §3.3). The energy of
// a site's label f (eq. 6) is
//   V1(f)  = ∓α   (eq. 9: −α if f agrees with membership of G1, +α otherwise)
//   V1(d|f) = ∓α  (eq. 10: −α if the observation's class d_s equals f)
//   Σ_s' V2(f, f_s') = ∓β              (eq. 11: −β same label, +β different)
//   Σ_s' V2(d, d'|f, f') = ∓γ·e^{−‖d_s − d_s'‖ / colour_scale}   (eq. 12, RGB difference)
// and f*(s) = argmin of the local energy given the neighbours (eq. 1 with eq. 2–5).
//
// Two solvers: kGibbs visits every pixel in raster sweeps until no label changes (iterated eq. 1
// over the whole image); kFloodFill follows the paper's pseudocode: from the seeds, a queue of
// neighbours is evaluated once each and only the neighbours of pixels that became label 1 are
// enqueued, so pixels of the other class far from the boundary are never visited.
#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "terramrf/image.hpp"

namespace terramrf::meshing {

enum class MrfMode { kFloodFill, kGibbs };
MrfMode parseMrfMode(const std::string& s);  ///< "flood_fill" | "gibbs"; throws otherwise
const char* toString(MrfMode m);

struct PixelMrfParams {
  double alpha = 1.0;          ///< eq. 9–10 weight [1]
  double beta = 0.6;           ///< eq. 11 weight [1]
  double gamma = 0.5;          ///< eq. 12 weight [1]
  double colour_scale = 10.0;  ///< RGB distance scale of eq. 12's exponent [grey levels]
  int max_sweeps = 20;         ///< kGibbs: sweeps at most
  MrfMode mode = MrfMode::kFloodFill;
};

struct PixelMrfResult {
  std::vector<uint8_t> label;  ///< per pixel (row-major): 1 = seeded class, 0 = other
  std::size_t evaluated = 0;   ///< local energy evaluations (work done)
  int sweeps = 0;              ///< kGibbs sweeps run
};

/// Solves the MRF. `seed` (G1′) and `observed` (d_s as a class, eq. 10) are per pixel 0/1;
/// `allowed` (optional, may be empty) marks pixels that may take label 1 — the others are fixed
/// to 0 (e.g. ground pixels in the object/background MRF). Seeds are fixed to 1.
PixelMrfResult solvePixelMrf(const Image& image, const std::vector<uint8_t>& seed,
                             const std::vector<uint8_t>& observed,
                             const std::vector<uint8_t>& allowed, const PixelMrfParams& p);

/// Colour model behind d_s: smoothed RGB histograms of the seeded class and of the other class;
/// observed(s) = 1 where the first is more likely (colours seen in neither count as class 0).
/// Histograms are kept per band of image rows as well, because haze shifts colours with distance
/// and distance follows the row; a band with too few samples falls back to the whole image.
class ColourModel {
 public:
  explicit ColourModel(int bins_per_channel = 16, int image_height = 0, int band_rows = 32);
  void add(const uint8_t* rgb, bool positive, int row = -1);
  /// Blurs the histograms (3×3×3 box) so near colours generalise; call once after adding.
  void finish();
  bool positive(const uint8_t* rgb, int row = -1) const;
  std::size_t count(bool positive) const { return positive ? n_pos_[0] : n_neg_[0]; }
  /// observed() for every pixel of an image.
  std::vector<uint8_t> classify(const Image& image) const;

 private:
  int bin(const uint8_t* rgb) const;
  int band(int row) const { return row < 0 || band_rows_ <= 0 ? 0 : 1 + std::min(row / band_rows_, bands_ - 1); }
  int bins_, shift_, bands_ = 0, band_rows_ = 0;
  std::size_t hsize_;
  std::vector<float> pos_, neg_;          // (1 + bands) histograms: 0 = whole image
  std::vector<std::size_t> n_pos_, n_neg_;
  std::vector<uint8_t> decision_;  // (1 + bands) × bins³, filled by finish()
  bool decide(int b, int row) const;
};

}  // namespace terramrf::meshing
