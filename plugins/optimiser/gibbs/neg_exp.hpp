#pragma once
// e^{−x} for the Gibbs sampler's conditionals: K exponentials per cell draw would otherwise
// dominate a sweep. Plain float arithmetic that an eight-lane version repeats operation by
// operation (colour_sweep.cpp), so both give the same bits; a table would need gathers, which
// cost more than the polynomial. Its own header so that the tests can measure its error.
#include <cstdint>
#include <cstring>

namespace terramrf {

struct NegExp {
  /// Beyond kMax the weight e^{−x} < 4.2e-8 is taken as 0: it is below 2^−24, the resolution of
  /// the uniform draw it is compared with, so the draw is certain.
  static constexpr float kMax = 17.f;
  static constexpr float kLog2e = 1.44269504f;
  /// 2^{−f} on [0, 1) as 1 + f·q(f), q interpolating (2^{−f} − 1)/f at five Chebyshev nodes:
  /// relative error 5.7e-7 in float, and exactly 1 at f = 0, so a certain draw's weight is 1.
  static constexpr float kC[6] = {
      1.f, -0.693146944f, 0.240214691f, -0.0554085597f, 0.00934423134f, -0.00100363046f};

  /// Whether e^{−x} is taken as exactly 0 (beyond kMax, or NaN).
  static bool zero(float x) { return !(x < kMax); }

  /// e^{−x} for x ≥ 0: y = x·log2(e) = n + f (n = ⌊y⌋), 2^{−f} by the polynomial (Horner, no
  /// fused multiply-add), 2^{−n} written into the exponent bits. Relative error below 1.5e-6,
  /// mostly from rounding y (< 25) to a float.
  static float eval(float x) {
    if (zero(x)) return 0.f;
    const float y = x * kLog2e;
    const int n = static_cast<int>(y);
    const float f = y - static_cast<float>(n);
    float p = kC[5];
    for (int c = 4; c >= 0; --c) p = p * f + kC[c];
    const uint32_t bits = uint32_t(127 - n) << 23;
    float scale;
    std::memcpy(&scale, &bits, sizeof scale);
    return p * scale;
  }
};

}  // namespace terramrf
