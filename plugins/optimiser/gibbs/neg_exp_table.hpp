#pragma once
// e^{−x} for the Gibbs sampler's conditionals: K exponentials per cell update would otherwise
// dominate a sweep. Its own header so that the tests can measure the error it is documented with.
#include <cmath>
#include <vector>

namespace terramrf {

/// e^{−x} for x ≥ 0 by linear interpolation in a table of kPerUnit steps per unit. The relative
/// error of linear interpolation of e^{−x} on a step h is at most h²/8 (the second derivative
/// relative to the value is 1), 3.05e-5 for h = 1/64, plus the float rounding of the entries
/// (≈ 6e-8): below 3.1e-5 everywhere. Beyond kMax the weight (< 1.3e-14) is taken as 0.
class NegExpTable {
 public:
  static constexpr float kMax = 32.f;
  static constexpr int kPerUnit = 64;

  NegExpTable() {
    tab_.resize(kSize + 2);
    for (int i = 0; i < kSize + 2; ++i)
      tab_[i] = static_cast<float>(std::exp(-double(i) / kPerUnit));
  }
  /// Whether the table gives exactly 0 for x (beyond kMax, or NaN).
  static bool zero(float x) { return !(x < kMax); }
  float operator()(float x) const {
    if (zero(x)) return 0.f;
    const float f = x * kPerUnit;
    const int i = static_cast<int>(f);
    const float t = f - static_cast<float>(i);
    return tab_[i] + t * (tab_[i + 1] - tab_[i]);
  }

 private:
  static constexpr int kSize = static_cast<int>(kMax) * kPerUnit;
  std::vector<float> tab_;
};

}  // namespace terramrf
