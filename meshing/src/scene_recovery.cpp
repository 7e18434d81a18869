#include "terramrf/meshing/scene_recovery.hpp"

#include <algorithm>
#include <cmath>

namespace terramrf::meshing {

namespace {
bool isObjectVertex(const Tile& t, int k) {
  return t.count[k] > 0 && t.object_votes[k] > t.ground_votes[k];
}

// d_s of the object/background MRF: RGB histograms (16 bins per channel, blurred by one bin) of
// the object seeds and of the background samples. The background samples are the pixels far
// from every LiDAR return: the sky, but also every object part above the LiDAR's reach (crowns,
// upper walls), whose colours are the seeds' colours. So a colour is background only where it
// is `odds` times more frequent among the background samples than among the seeds; colours seen
// in neither are background (the sky is never sensed, object colours are).
class ObjectColours {
 public:
  void add(const uint8_t* rgb, bool object) {
    (object ? obj_ : bg_)[bin(rgb)] += 1;
    ++(object ? n_obj_ : n_bg_);
  }
  std::vector<uint8_t> classify(const Image& img, double odds) {
    blur(obj_);
    blur(bg_);
    std::vector<uint8_t> decide(kBins * kBins * kBins);
    for (std::size_t b = 0; b < decide.size(); ++b) {
      const double po = n_obj_ ? obj_[b] / double(n_obj_) : 0.0;
      const double pb = n_bg_ ? bg_[b] / double(n_bg_) : 0.0;
      decide[b] = po > 0 && odds * po >= pb ? 1 : 0;
    }
    std::vector<uint8_t> out(std::size_t(img.width) * img.height);
    for (std::size_t s = 0; s < out.size(); ++s) out[s] = decide[bin(&img.data[s * 3])];
    return out;
  }

 private:
  static constexpr int kBins = 16;
  static int bin(const uint8_t* c) { return ((c[0] >> 4) * kBins + (c[1] >> 4)) * kBins + (c[2] >> 4); }
  static void blur(std::vector<float>& h) {
    std::vector<float> tmp(h.size());
    for (int stride : {kBins * kBins, kBins, 1}) {
      for (int i = 0; i < int(h.size()); ++i) {
        const int c = (i / stride) % kBins;
        tmp[i] = h[i] + (c > 0 ? h[i - stride] : 0.f) + (c + 1 < kBins ? h[i + stride] : 0.f);
      }
      h.swap(tmp);
    }
  }
  std::vector<float> obj_ = std::vector<float>(kBins * kBins * kBins, 0.f), bg_ = obj_;
  std::size_t n_obj_ = 0, n_bg_ = 0;
};
}  // namespace

SceneRecoveryStats recoverHeights(TerrainMesh& mesh, const CameraView& view, const Image& image,
                                  const GroundSegmentation& ground, const PointCloud& points,
                                  const SceneRecoveryParams& p) {
  SceneRecoveryStats st;
  const int W = image.width, H = image.height;
  const std::size_t N = std::size_t(W) * H;
  if (ground.ground.size() != N) return st;
  const int span = mesh.tileSpan();
  const double cell = mesh.params().cell_m, L = span * cell;
  const Eigen::Vector3d C = view.centre();

  // ---- object seeds: visible object vertices and the frame's non-ground LiDAR pixels --------
  std::vector<uint8_t> seed(N, 0), allowed(N, 0);
  for (std::size_t s = 0; s < N; ++s) allowed[s] = ground.ground[s] ? 0 : 1;
  ObjectColours colours;
  struct Candidate {
    Tile* tile;
    int k;
    Eigen::Vector3d p;
    Eigen::Vector2d uv;
    double depth;
  };
  std::vector<Candidate> cands;
  for (auto& [key, tp] : mesh.tiles()) {
    Tile& t = *tp;
    const double x0 = t.ti * L, y0 = t.tj * L;
    const double dx = std::max({x0 - C.x(), 0.0, C.x() - (x0 + L)});
    const double dy = std::max({y0 - C.y(), 0.0, C.y() - (y0 + L)});
    if (dx * dx + dy * dy > p.max_range_m * p.max_range_m) continue;
    for (int i = 0; i < t.n; ++i) {
      for (int j = 0; j < t.n; ++j) {
        const int k = i * t.n + j;
        if (!isObjectVertex(t, k)) continue;
        // A border vertex is in two to four tiles: handled from one, it is tried (and counted)
        // once, as in the votes.
        if (!mesh.owns(t, i, j)) continue;
        const Eigen::Vector3d pw(x0 + i * cell, y0 + j * cell, t.z_max[k]);
        if ((pw.head<2>() - C.head<2>()).norm() > p.max_range_m) continue;
        double depth = 0;
        const auto uv = view.project(pw, &depth);
        if (!uv) continue;
        const int u = int(uv->x() + 0.5), v = int(uv->y() + 0.5);
        if (u >= W || v >= H || !view.visible(u, v, depth)) continue;
        const std::size_t s = std::size_t(v) * W + u;
        if (!allowed[s]) continue;  // vertex lands on a ground pixel: no object here in this view
        seed[s] = 1;
        cands.push_back({&t, k, pw, *uv, depth});
      }
    }
  }
  const auto& cam = view.camera();
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto uv = cam.project(Eigen::Vector3d(points.x[i], points.y[i], points.z[i]));
    if (!uv) continue;
    const int u = int(uv->x() + 0.5), v = int(uv->y() + 0.5);
    if (u >= W || v >= H) continue;
    const std::size_t s = std::size_t(v) * W + u;
    if (allowed[s]) seed[s] = 1;
  }
  std::size_t n_seed = 0;
  for (std::size_t s = 0; s < N; ++s) {
    if (seed[s]) {
      colours.add(&image.data[s * 3], true);
      ++n_seed;
    }
  }
  if (!n_seed) return st;
  // Background samples: non-ground pixels far from any LiDAR return (sky is never sensed).
  {
    const int r = p.background_clearance_px;
    for (int v = 0; v < H; v += 2) {
      for (int u = 0; u < W; u += 2) {
        const std::size_t s = std::size_t(v) * W + u;
        if (!allowed[s] || seed[s]) continue;
        bool near = false;
        for (int dv = -r; dv <= r && !near; dv += std::max(1, r / 2))
          for (int du = -r; du <= r && !near; du += std::max(1, r / 2)) {
            const int uu = std::clamp(u + du, 0, W - 1), vv = std::clamp(v + dv, 0, H - 1);
            near = std::isfinite(view.lidarDepth(uu, vv));
          }
        if (!near) colours.add(&image.data[s * 3], false);
      }
    }
  }
  const std::vector<uint8_t> observed = colours.classify(image, p.background_odds);
  PixelMrfResult mrf = solvePixelMrf(image, seed, observed, allowed, p.mrf);
  const std::vector<uint8_t>& obj = mrf.label;

  // ---- follow the vertical above each vertex to the object's top boundary ------------------
  for (const Candidate& c : cands) {
    ++st.vertices_tried;
    const auto up = view.project(c.p + Eigen::Vector3d(0, 0, 1.0));
    Eigen::Vector2d dir(0, -1);
    if (up && (*up - c.uv).norm() > 1e-6) dir = (*up - c.uv).normalized();
    int last = -1, gap = 0;
    bool left_image = false, occluded = false;
    for (int t = 0;; ++t) {
      const Eigen::Vector2d q = c.uv + t * dir;
      // floor, not a cast: the march leaves the image through negative coordinates too
      const int u = int(std::floor(q.x() + 0.5)), v = int(std::floor(q.y() + 0.5));
      if (u < 0 || v < 0 || u >= W || v >= H) {
        left_image = v < 0 && gap == 0;
        break;
      }
      const std::size_t s = std::size_t(v) * W + u;
      // A LiDAR surface clearly behind the vertex: the column has passed onto another object.
      if (view.lidarDepth(u, v) > c.depth + p.depth_jump_m + 0.05 * c.depth &&
          std::isfinite(view.lidarDepth(u, v)))
        break;
      // A clearly nearer surface covers the column (a crown or car in front of a wall): the
      // boundary above it would be the occluder's, so the walk ends here with a lower bound.
      if (p.stop_at_occluders && t > 0 && !view.visible(u, v, c.depth)) {
        occluded = true;
        break;
      }
      if (obj[s]) {
        last = t;
        gap = 0;
      } else if (++gap > p.max_gap_px) {
        break;
      }
    }
    if (last < 0) continue;
    // Ray through the top edge of the boundary pixel, intersected with the vertical at the
    // vertex's horizontal position.
    const Eigen::Vector2d b = c.uv + (last + 0.5) * dir;
    const Eigen::Vector3d d = view.ray(b.x(), b.y());
    const Eigen::Vector2d dxy = d.head<2>();
    if (dxy.squaredNorm() < 1e-12) continue;
    const double s = (c.p.head<2>() - C.head<2>()).dot(dxy) / dxy.squaredNorm();
    if (s <= 0) continue;
    const double z = C.z() + s * d.z();
    const double range = std::max(1.0, (c.p.head<2>() - C.head<2>()).norm());
    Tile& t = *c.tile;
    const int i = c.k / t.n, j = c.k % t.n;
    const VertexKey key{int64_t(t.ti) * span + i, int64_t(t.tj) * span + j};
    if (occluded) ++st.occluded;
    if (left_image || occluded) {
      ++st.lower_bounds;
      mesh.forEachCopy(key, [&](Tile& tt, int kk) {
        if (!(tt.rec_lower[kk] >= z)) tt.rec_lower[kk] = float(z);
      });
      continue;
    }
    ++st.estimates;
    if (z <= t.z_max[c.k]) continue;  // the LiDAR already saw the top
    ++st.raised;
    // Weight 1/range⁴: close views are sharper.
    mesh.addHeightEstimate(key, z, 1.0 / (range * range * range * range));
  }
  st.object_mask = obj;
  return st;
}

}  // namespace terramrf::meshing
