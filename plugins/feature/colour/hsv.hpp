#pragma once
// RGB → HSV of one pixel, the definition of OpenCV's RGB2HSV for float images, computed here in
// plain scalar arithmetic: cv::cvtColor picks a vector kernel at run time (SSE2, AVX2 with fused
// multiply-adds, …), whose hue differs from the others in the last bits, so the same image gave
// other colour_h values on another CPU (or with OPENCV_CPU_DISABLE=AVX2). Each operation below
// is one IEEE operation in single precision (the division in double, as OpenCV's scalar path),
// and the plugin is built with -ffp-contract=off, so no compiler fuses them either: the same
// bits on every x86-64 CPU.
//
//   V = max(R, G, B)                                  in [0, 1] for inputs in [0, 1]
//   S = (V − min) / (V + ε)                           in [0, 1], ε = FLT_EPSILON (0 for black)
//   H = 60° · (G − B) / (V − min + ε)          if V = R
//       60° · (B − R) / (V − min + ε) + 120°   if V = G
//       60° · (R − G) / (V − min + ε) + 240°   otherwise,  + 360° if negative;  in [0°, 360°)
// Grey (V = min) gets H = 0 and S = 0, as in OpenCV.
#include <cfloat>

namespace terramrf::colour {

inline void rgbToHsv(float r, float g, float b, float& h, float& s, float& v) {
  float hi = r, lo = r;
  if (hi < g) hi = g;
  if (hi < b) hi = b;
  if (lo > g) lo = g;
  if (lo > b) lo = b;
  const float d = hi - lo;
  v = hi;
  s = d / (hi + FLT_EPSILON);  // inputs are ≥ 0: OpenCV's |V| is V
  const float k = float(60.0 / (double(d) + FLT_EPSILON));
  float hue;
  if (hi == r)
    hue = (g - b) * k;
  else if (hi == g)
    hue = (b - r) * k + 120.f;
  else
    hue = (r - g) * k + 240.f;
  if (hue < 0) hue += 360.f;
  // A tiny negative hue plus 360 rounds to 360 in single precision: the same direction as 0,
  // and the documented range is [0, 360).
  h = hue >= 360.f ? 0.f : hue;
}

}  // namespace terramrf::colour
