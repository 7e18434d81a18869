#include "terramrf/meshing/pixel_mrf.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace terramrf::meshing {

MrfMode parseMrfMode(const std::string& s) {
  if (s == "flood_fill") return MrfMode::kFloodFill;
  if (s == "gibbs") return MrfMode::kGibbs;
  throw std::invalid_argument("unknown MRF mode '" + s + "'; expected flood_fill or gibbs");
}

const char* toString(MrfMode m) { return m == MrfMode::kFloodFill ? "flood_fill" : "gibbs"; }

namespace {

// Local energy difference E(1) − E(0) of pixel s given its neighbours' labels.
class LocalEnergy {
 public:
  LocalEnergy(const Image& img, const std::vector<uint8_t>& seed, const std::vector<uint8_t>& obs,
              const PixelMrfParams& p)
      : img_(img), seed_(seed), obs_(obs), w_(img.width), h_(img.height) {
    unary_seed_ = -2 * p.alpha;  // V9 only; seeds are fixed anyway
    two_alpha_ = 2 * p.alpha;
    two_beta_ = 2 * p.beta;
    // exp(−d / scale) for integer RGB distances 0..442.
    lut_.resize(443);
    for (int d = 0; d < 443; ++d) lut_[d] = float(2 * p.gamma * std::exp(-d / p.colour_scale));
  }

  float contrast(int s, int t) const {
    const uint8_t* a = &img_.data[std::size_t(s) * 3];
    const uint8_t* b = &img_.data[std::size_t(t) * 3];
    const int d0 = int(a[0]) - b[0], d1 = int(a[1]) - b[1], d2 = int(a[2]) - b[2];
    const int d = int(std::sqrt(float(d0 * d0 + d1 * d1 + d2 * d2)) + 0.5f);
    return lut_[d];
  }

  /// ΔE = E(f=1) − E(f=0); label 1 wins when negative.
  float delta(int s, const std::vector<uint8_t>& label) const {
    // eq. 9: s ∉ G1 here (seeds are fixed) → +α for 1, −α for 0. eq. 10: −α if d_s = f.
    float e = float(two_alpha_) + (obs_[s] ? -float(two_alpha_) : float(two_alpha_));
    const int u = s % w_, v = s / w_;
    auto pair = [&](int t) {
      const float k = float(two_beta_) + contrast(s, t);
      e += label[t] ? -k : k;
    };
    if (u > 0) pair(s - 1);
    if (u + 1 < w_) pair(s + 1);
    if (v > 0) pair(s - w_);
    if (v + 1 < h_) pair(s + w_);
    return e;
  }

 private:
  const Image& img_;
  const std::vector<uint8_t>& seed_;
  const std::vector<uint8_t>& obs_;
  int w_, h_;
  double unary_seed_, two_alpha_, two_beta_;
  std::vector<float> lut_;
};

}  // namespace

PixelMrfResult solvePixelMrf(const Image& image, const std::vector<uint8_t>& seed,
                             const std::vector<uint8_t>& observed,
                             const std::vector<uint8_t>& allowed, const PixelMrfParams& p) {
  if (image.channels != 3) throw std::invalid_argument("pixel MRF needs an RGB image");
  const int W = image.width, H = image.height, N = W * H;
  if (int(seed.size()) != N || int(observed.size()) != N || (!allowed.empty() && int(allowed.size()) != N))
    throw std::invalid_argument("pixel MRF: seed/observed/allowed sizes differ from the image");
  const bool masked = !allowed.empty();
  LocalEnergy E(image, seed, observed, p);
  PixelMrfResult r;
  // Initial configuration: seeds 1, other pixels their observation (0 where not allowed).
  r.label.resize(N);
  for (int s = 0; s < N; ++s) {
    const bool ok = !masked || allowed[s];
    r.label[s] = seed[s] ? 1 : (ok ? observed[s] : 0);
  }
  std::vector<uint8_t>& f = r.label;

  if (p.mode == MrfMode::kGibbs) {
    for (r.sweeps = 0; r.sweeps < p.max_sweeps;) {
      ++r.sweeps;
      std::size_t changed = 0;
      for (int s = 0; s < N; ++s) {
        if (seed[s] || (masked && !allowed[s])) continue;
        const uint8_t nf = E.delta(s, f) < 0 ? 1 : 0;
        ++r.evaluated;
        if (nf != f[s]) {
          f[s] = nf;
          ++changed;
        }
      }
      if (!changed) break;
    }
    return r;
  }

  // Flood fill (paper's pseudocode): everything not reached from a seed is label 0.
  std::vector<uint8_t> state(N, 0);  // 0 = not queued, 1 = queued/decided
  std::vector<int> queue;
  queue.reserve(std::size_t(N) / 2);
  for (int s = 0; s < N; ++s) {
    if (seed[s]) state[s] = 1;
  }
  auto pushNeighbours = [&](int s) {
    const int u = s % W, v = s / W;
    const int nb[4] = {u > 0 ? s - 1 : -1, u + 1 < W ? s + 1 : -1, v > 0 ? s - W : -1,
                       v + 1 < H ? s + W : -1};
    for (int t : nb) {
      if (t < 0 || state[t]) continue;
      state[t] = 1;
      queue.push_back(t);
    }
  };
  for (int s = 0; s < N; ++s)
    if (seed[s]) pushNeighbours(s);
  for (std::size_t head = 0; head < queue.size(); ++head) {
    const int s = queue[head];
    if (masked && !allowed[s]) {
      f[s] = 0;
      continue;
    }
    ++r.evaluated;
    if (E.delta(s, f) < 0) {
      f[s] = 1;
      pushNeighbours(s);
    } else {
      f[s] = 0;
    }
  }
  // Pixels never reached keep no label 1.
  for (int s = 0; s < N; ++s)
    if (!state[s]) f[s] = 0;
  return r;
}

ColourModel::ColourModel(int bins, int image_height, int band_rows) : bins_(bins) {
  if (bins != 8 && bins != 16 && bins != 32) throw std::invalid_argument("colour bins must be 8, 16 or 32");
  shift_ = bins == 8 ? 5 : bins == 16 ? 4 : 3;
  if (image_height > 0 && band_rows > 0) {
    band_rows_ = band_rows;
    bands_ = (image_height + band_rows - 1) / band_rows;
  }
  hsize_ = std::size_t(bins) * bins * bins;
  pos_.assign(hsize_ * (1 + bands_), 0.f);
  neg_ = pos_;
  n_pos_.assign(1 + bands_, 0);
  n_neg_.assign(1 + bands_, 0);
}

int ColourModel::bin(const uint8_t* c) const {
  return ((c[0] >> shift_) * bins_ + (c[1] >> shift_)) * bins_ + (c[2] >> shift_);
}

void ColourModel::add(const uint8_t* rgb, bool positive, int row) {
  decision_.clear();
  const int b = bin(rgb), k = band(row);
  auto& h = positive ? pos_ : neg_;
  auto& n = positive ? n_pos_ : n_neg_;
  h[b] += 1;
  ++n[0];
  if (k > 0) {
    h[hsize_ * k + b] += 1;
    ++n[k];
  }
}

void ColourModel::finish() {
  const int B = bins_;
  std::vector<float> tmp(hsize_);
  auto blur = [&](float* h) {
    // Separable box blur along r, g, b.
    for (int axis = 0; axis < 3; ++axis) {
      const int stride = axis == 0 ? B * B : axis == 1 ? B : 1;
      for (int i = 0; i < int(hsize_); ++i) {
        const int c = (i / stride) % B;
        float s = h[i];
        if (c > 0) s += h[i - stride];
        if (c + 1 < B) s += h[i + stride];
        tmp[i] = s;
      }
      std::copy(tmp.begin(), tmp.end(), h);
    }
  };
  for (int k = 0; k <= bands_; ++k) {
    if (n_pos_[k]) blur(&pos_[hsize_ * k]);
    if (n_neg_[k]) blur(&neg_[hsize_ * k]);
  }
  // Decisions per band and colour bin, so classifying a pixel is one lookup.
  decision_.assign(hsize_ * (1 + bands_), 0);
  for (int k = 0; k <= bands_; ++k) {
    const int row = k == 0 ? -1 : (k - 1) * band_rows_;
    for (int b = 0; b < int(hsize_); ++b) decision_[hsize_ * k + b] = decide(b, row) ? 1 : 0;
  }
}

bool ColourModel::positive(const uint8_t* rgb, int row) const {
  const int b = bin(rgb), k = band(row);
  if (!decision_.empty()) return decision_[hsize_ * k + b] != 0;
  return decide(b, row);
}

bool ColourModel::decide(int b, int row) const {
  constexpr std::size_t kMinSamples = 50;
  // Each class from the nearest row band with enough samples of it (the whole image if none).
  auto nearest = [&](const std::vector<std::size_t>& n) {
    const int k = band(row);
    if (k == 0) return 0;
    for (int d = 0; d < bands_; ++d) {
      if (k - d >= 1 && n[k - d] >= kMinSamples) return k - d;
      if (k + d <= bands_ && n[k + d] >= kMinSamples) return k + d;
    }
    return 0;
  };
  const int kp = nearest(n_pos_), kn = nearest(n_neg_);
  const float p = pos_[hsize_ * kp + b];
  if (p <= 0) return false;
  if (n_neg_[kn] == 0) return true;
  return p / float(n_pos_[kp]) > neg_[hsize_ * kn + b] / float(n_neg_[kn]);
}

std::vector<uint8_t> ColourModel::classify(const Image& img) const {
  std::vector<uint8_t> out(std::size_t(img.width) * img.height);
  for (int v = 0; v < img.height; ++v)
    for (int u = 0; u < img.width; ++u) {
      const std::size_t s = std::size_t(v) * img.width + u;
      out[s] = positive(&img.data[s * 3], v) ? 1 : 0;
    }
  return out;
}

}  // namespace terramrf::meshing
