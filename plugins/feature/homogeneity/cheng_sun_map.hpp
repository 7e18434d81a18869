#pragma once
// Cheng & Sun's per-pixel homogeneity H = 1 − E·V of an 8-bit grey image, computed row by row
// in one pass (docs/plugins/camera_features.md has the definition):
//   e² = Gx² + Gy² from the 3 × 3 Sobel derivatives,
//   N²v² = N·ΣI² − (ΣI)² over the d × d window (N = d²), exact in 32-bit integers,
//   H = 1 − √(e² · N²v²) · k   (fixed bounds)   or   1 − √(e² · N²v²) / ev_max   (image maxima).
// At the image border both use OpenCV's BORDER_REFLECT_101. The integers are the ones OpenCV's
// boxFilter, sqrBoxFilter and spatialGradient give (a test compares them bit for bit), but no
// intermediate image is written: the window's column sums are carried from row to row (one row
// in, one out) and each row's sums live in a few L1-sized buffers. On a KITTI image that is
// 60 % fewer instructions than those four filters and the pass that combined their images.
// `spread` gives the plugin's local_std, 1 − √(N²v²) / nv_max, from the same rows.
#include <cstdint>
#include <vector>

namespace terramrf {

class ChengSunMap {
 public:
  /// Scratch rows are sized for `cols` and `window` (odd, 3–15) and reused between calls.
  /// `grey` is a rows × cols row-major image; rows [r0, r1) of H are written to `h` (row-major,
  /// (r1 − r0) × cols).
  void fixed(const uint8_t* grey, int rows, int cols, int window, int r0, int r1, float k,
             float* h);
  /// Largest e² and N²v² over rows [r0, r1) (for normalise: image).
  void maxima(const uint8_t* grey, int rows, int cols, int window, int r0, int r1, uint32_t* e2_max,
              uint32_t* v2_max);
  /// H = 1 − √(e² · N²v²) / ev_max over rows [r0, r1).
  void image(const uint8_t* grey, int rows, int cols, int window, int r0, int r1, float ev_max,
             float* h);
  /// The spread alone (the plugin's local_std): 1 − √(N²v²) / nv_max over rows [r0, r1).
  void spread(const uint8_t* grey, int rows, int cols, int window, int r0, int r1, double nv_max,
              float* h);

  /// e² and N²v² of row r, as the filters give them (for the tests; valid until the next call).
  void rowProducts(const uint8_t* grey, int rows, int cols, int window, int r, const uint32_t** e2,
                   const uint32_t** v2);

 private:
  /// Sizes the rows, checks the window and reads the instruction set (once per call of the
  /// public functions).
  void reserve(int cols, int window);
  /// e² and N²v² of row r into e2_ and v2_; `running`: the column sums hold row r − 1's.
  void row(const uint8_t* grey, int rows, int cols, int r, bool running);

  std::vector<uint16_t> col_s_;  // ΣI down the window's rows, per column, padded by d/2 each side
  std::vector<uint32_t> col_q_;  // ΣI², the same
  std::vector<uint8_t> sobel_rows_;  // rows r − 1, r, r + 1, padded by one pixel each side
  std::vector<uint32_t> e2_, v2_;
  bool avx2_ = false;
  int half_ = 1;  // window / 2
};

}  // namespace terramrf
