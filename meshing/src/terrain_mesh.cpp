#include "terramrf/meshing/terrain_mesh.hpp"

#include <algorithm>
#include <cstdio>
#include <stdexcept>
#include <string>

#include "terramrf/text_format.hpp"

namespace terramrf::meshing {

const char* toString(VertexClass c) {
  switch (c) {
    case VertexClass::kUnknown: return "unknown";
    case VertexClass::kGround: return "ground";
    case VertexClass::kObject: return "object";
    case VertexClass::kTree: return "tree";
    case VertexClass::kBuilding: return "building";
  }
  return "invalid";
}

namespace {
/// Bytes of one vertex across the Tile's per-vertex arrays (taken from their types, so a new or
/// wider field counts without this being edited; a new array must be added here).
constexpr std::size_t kVertexBytes =
    sizeof(decltype(Tile::z_max)::value_type) + sizeof(decltype(Tile::z_min)::value_type) +
    sizeof(decltype(Tile::z_sum)::value_type) + sizeof(decltype(Tile::count)::value_type) +
    sizeof(decltype(Tile::ground_votes)::value_type) +
    sizeof(decltype(Tile::object_votes)::value_type) + sizeof(decltype(Tile::rec_sum)::value_type) +
    sizeof(decltype(Tile::rec_weight)::value_type) + sizeof(decltype(Tile::rec_lower)::value_type) +
    sizeof(decltype(Tile::cls)::value_type) + sizeof(decltype(Tile::mask_response)::value_type);
/// Bytes of one texel: RGB plus its camera distance.
constexpr std::size_t kTexelBytes = 3 + sizeof(decltype(Tile::texel_range)::value_type);

double textureSide(const TerrainMeshParams& p) {
  return double(p.tile_vertices - 1) * p.texels_per_cell + 1;
}
}  // namespace

double tileBytes(const TerrainMeshParams& p) {
  const double n = p.tile_vertices, T = textureSide(p);
  return n * n * kVertexBytes + T * T * kTexelBytes;
}

std::string tileBudgetProblem(const TerrainMeshParams& p) {
  const double bytes = tileBytes(p);
  if (bytes <= kMaxTileBytes) return "";
  const double n = p.tile_vertices, T = textureSide(p);
  char sizes[160];
  std::snprintf(sizes, sizeof sizes, "%.0f x %.0f vertices: %s, a %.0f x %.0f texel texture: %s", n,
                n, byteSize(n * n * kVertexBytes).c_str(), T, T,
                byteSize(T * T * kTexelBytes).c_str());
  return "tile_vertices " + std::to_string(p.tile_vertices) + " with texels_per_cell " +
         std::to_string(p.texels_per_cell) + " makes tiles of " + byteSize(bytes) + " each (" +
         sizes + "); expected at most " + byteSize(kMaxTileBytes) +
         " per tile: every tile is allocated whole as soon as a point falls in it. Lower "
         "texels_per_cell or tile_vertices (the defaults, 151 and 2: " +
         byteSize(tileBytes(TerrainMeshParams{})) + " per tile)";
}

TerrainMesh::TerrainMesh(const TerrainMeshParams& p) : p_(p) {
  if (p_.tile_vertices < 2)
    throw std::invalid_argument("tile_vertices must be >= 2, got " + std::to_string(p_.tile_vertices));
  if (!(p_.cell_m > 0)) throw std::invalid_argument("cell_m must be > 0");
  if (p_.texels_per_cell < 1) throw std::invalid_argument("texels_per_cell must be >= 1");
  // Refused here, not at the first point: a run would otherwise fail (or be killed) mid-drive.
  if (const std::string why = tileBudgetProblem(p_); !why.empty()) throw std::invalid_argument(why);
}

void TerrainMesh::tileOf(int64_t gi, int64_t gj, int& ti, int& tj) const {
  ti = int(floorDiv(gi, tileSpan()));
  tj = int(floorDiv(gj, tileSpan()));
}

const Tile* TerrainMesh::ownerOf(int64_t gi, int64_t gj) const {
  int ti, tj;
  tileOf(gi, gj, ti, tj);
  const int span = tileSpan();
  const std::pair<int, int> order[4] = {{ti, tj}, {ti, tj - 1}, {ti - 1, tj}, {ti - 1, tj - 1}};
  for (const auto& key : order) {
    auto it = tiles_.find(key);
    if (it == tiles_.end()) continue;
    const Tile& t = *it->second;
    const int64_t i = gi - int64_t(t.ti) * span, j = gj - int64_t(t.tj) * span;
    if (i >= 0 && j >= 0 && i < t.n && j < t.n) return &t;
  }
  return nullptr;
}

const Tile* TerrainMesh::tile(int ti, int tj) const {
  auto it = tiles_.find({ti, tj});
  return it == tiles_.end() ? nullptr : it->second.get();
}

Tile& TerrainMesh::ensureTile(int ti, int tj) {
  auto& slot = tiles_[{ti, tj}];
  if (slot) return *slot;
  slot = std::make_unique<Tile>();
  Tile& t = *slot;
  t.ti = ti;
  t.tj = tj;
  t.n = p_.tile_vertices;
  const std::size_t nv = t.vertices();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  t.z_max.assign(nv, nan);
  t.z_min.assign(nv, nan);
  t.z_sum.assign(nv, 0.0);
  t.count.assign(nv, 0);
  t.ground_votes.assign(nv, 0);
  t.object_votes.assign(nv, 0);
  t.rec_sum.assign(nv, 0.0);
  t.rec_weight.assign(nv, 0.0);
  t.rec_lower.assign(nv, nan);
  t.cls.assign(nv, VertexClass::kUnknown);
  t.mask_response.assign(nv, nan);
  const int T = textureSize();
  t.texture = Image(T, T, 3);
  std::fill(t.texture.data.begin(), t.texture.data.end(), uint8_t(128));  // grey = no image
  t.texel_range.assign(std::size_t(T) * T, std::numeric_limits<float>::infinity());
  // Copy the shared border vertices from the neighbours that already exist.
  const int span = tileSpan();
  for (int di = -1; di <= 1; ++di) {
    for (int dj = -1; dj <= 1; ++dj) {
      if (!di && !dj) continue;
      auto it = tiles_.find({ti + di, tj + dj});
      if (it == tiles_.end()) continue;
      const Tile& o = *it->second;
      for (int i = 0; i < t.n; ++i) {
        const int oi = i - di * span;
        if (oi < 0 || oi >= o.n) continue;
        for (int j = 0; j < t.n; ++j) {
          const int oj = j - dj * span;
          if (oj < 0 || oj >= o.n) continue;
          const int k = i * t.n + j, ok = oi * o.n + oj;
          t.z_max[k] = o.z_max[ok];
          t.z_min[k] = o.z_min[ok];
          t.z_sum[k] = o.z_sum[ok];
          t.count[k] = o.count[ok];
          t.ground_votes[k] = o.ground_votes[ok];
          t.object_votes[k] = o.object_votes[ok];
          t.rec_sum[k] = o.rec_sum[ok];
          t.rec_weight[k] = o.rec_weight[ok];
          t.rec_lower[k] = o.rec_lower[ok];
          t.cls[k] = o.cls[ok];
        }
      }
      // The shared texels too: a texel baked before this tile existed would stay grey here and
      // show a seam along the border in the export.
      const int tspan = span * p_.texels_per_cell;
      for (int a = 0; a < T; ++a) {
        const int oa = a - di * tspan;
        if (oa < 0 || oa >= T) continue;
        for (int b = 0; b < T; ++b) {
          const int ob = b - dj * tspan;
          if (ob < 0 || ob >= T) continue;
          std::copy_n(o.texture.at(ob, oa), 3, t.texture.at(b, a));
          t.texel_range[std::size_t(a) * T + b] = o.texel_range[std::size_t(oa) * T + ob];
        }
      }
    }
  }
  return t;
}

void TerrainMesh::addPoint(const Eigen::Vector3d& p) {
  if (!p.allFinite()) return;
  const int64_t gi = int64_t(std::floor(p.x() / p_.cell_m + 0.5));
  const int64_t gj = int64_t(std::floor(p.y() / p_.cell_m + 0.5));
  // The point's own tile (half-open: x ∈ [ti·L, (ti+1)·L)) is created only if missing, i.e. when
  // the point lies outside every tile (paper §3.1). Its nearest vertex can be that tile's far
  // border, which must not create the next tile: a point at x = 18.70 m in a tile ending at
  // 18.75 m did, and the new tile held nothing but that border.
  const double L = tileSpan() * p_.cell_m;
  ensureTile(int(std::floor(p.x() / L)), int(std::floor(p.y() / L)));
  const float z = float(p.z());
  forEachCopy({gi, gj}, [&](Tile& t, int k) {
    if (t.count[k] == 0) {
      t.z_max[k] = t.z_min[k] = z;
    } else {
      t.z_max[k] = std::max(t.z_max[k], z);
      t.z_min[k] = std::min(t.z_min[k], z);
    }
    t.z_sum[k] += p.z();  // the point's own height, not its float rounding (~3e-5 m at 300 m)
    ++t.count[k];
  });
}

void TerrainMesh::addHeightEstimate(const VertexKey& key, double z_m, double weight) {
  forEachCopy(key, [&](Tile& t, int k) {
    t.rec_sum[k] += weight * z_m;
    t.rec_weight[k] += weight;
  });
}

std::size_t TerrainMesh::addCloud(const PointCloud& cloud, const Eigen::Isometry3d& T,
                                  double max_range_m) {
  std::size_t skipped = 0;
  const double r2 = max_range_m * max_range_m;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const double x = cloud.x[i], y = cloud.y[i];
    if (x * x + y * y > r2) {
      ++skipped;
      continue;
    }
    addPoint(T * Eigen::Vector3d(x, y, cloud.z[i]));
  }
  return skipped;
}

float TerrainMesh::displayHeight(const Tile& t, int k) const {
  if (t.count[k] == 0) return std::numeric_limits<float>::quiet_NaN();
  const VertexClass c = t.cls[k];
  if (c == VertexClass::kGround || c == VertexClass::kUnknown)
    return float(t.z_sum[k] / t.count[k]);
  float h = t.z_max[k];
  if (t.rec_weight[k] > 0) h = std::max(h, float(t.rec_sum[k] / t.rec_weight[k]));
  // The lower bound is measured (the object reaches at least there), so an estimate below it
  // from another view is wrong and must not win.
  if (std::isfinite(t.rec_lower[k])) h = std::max(h, t.rec_lower[k]);
  return h;
}

Eigen::Vector3d TerrainMesh::vertexPosition(const Tile& t, int i, int j) const {
  const int span = tileSpan();
  return {double(int64_t(t.ti) * span + i) * p_.cell_m, double(int64_t(t.tj) * span + j) * p_.cell_m,
          double(displayHeight(t, i * t.n + j))};
}

Eigen::Vector2f TerrainMesh::vertexUv(int i, int j) const {
  const float T = float(textureSize());
  const int tpc = p_.texels_per_cell;
  // Texel centres; v flipped because image rows grow downwards while OBJ/glTF v grows upwards
  // for OBJ. glTF flips back (see the exporters).
  return {(float(j * tpc) + 0.5f) / T, 1.0f - (float(i * tpc) + 0.5f) / T};
}

std::size_t TerrainMesh::bakeTexture(const CameraView& view, const Image& image,
                                     double max_range_m) {
  if (image.empty() || image.channels < 1) return 0;
  // A different size would clamp every projection to the image edge: colours from wrong pixels.
  if (image.width != view.width() || image.height != view.height())
    throw std::invalid_argument("texture baking: image of camera '" + view.camera().name + "' is " +
                                std::to_string(image.width) + "x" + std::to_string(image.height) +
                                " px; expected the camera model's " + std::to_string(view.width()) +
                                "x" + std::to_string(view.height()));
  const Eigen::Vector3d cam_w = view.centre();
  const int span = tileSpan(), tpc = p_.texels_per_cell, T = textureSize();
  const double L = span * p_.cell_m, step = p_.cell_m / tpc;
  std::size_t updated = 0;
  for (auto& [key, tp] : tiles_) {
    Tile& t = *tp;
    const double x0 = t.ti * L, y0 = t.tj * L;
    // Skip tiles entirely out of range.
    const double dx = std::max({x0 - cam_w.x(), 0.0, cam_w.x() - (x0 + L)});
    const double dy = std::max({y0 - cam_w.y(), 0.0, cam_w.y() - (y0 + L)});
    if (dx * dx + dy * dy > max_range_m * max_range_m) continue;
    for (int a = 0; a < T; ++a) {
      const int i0 = a / tpc;
      const double fa = double(a % tpc) / tpc;
      for (int b = 0; b < T; ++b) {
        const int j0 = b / tpc;
        const double fb = double(b % tpc) / tpc;
        // Elevation: NaN-aware bilinear over the cell's corner vertices.
        double zs = 0, ws = 0;
        for (int di = 0; di <= 1; ++di) {
          const int i = std::min(i0 + di, t.n - 1);
          const double wi = di ? fa : 1 - fa;
          if (wi <= 0) continue;
          for (int dj = 0; dj <= 1; ++dj) {
            const int j = std::min(j0 + dj, t.n - 1);
            const double wj = dj ? fb : 1 - fb;
            if (wj <= 0) continue;
            const float h = displayHeight(t, i * t.n + j);
            if (std::isnan(h)) continue;
            zs += wi * wj * h;
            ws += wi * wj;
          }
        }
        if (ws <= 0) continue;
        const Eigen::Vector3d pw(x0 + a * step, y0 + b * step, zs / ws);
        const float range = float((pw - cam_w).norm());
        const std::size_t tk = std::size_t(a) * T + b;
        if (!(range < t.texel_range[tk]) || range > max_range_m) continue;
        double depth = 0;
        const auto uv = view.project(pw, &depth);
        if (!uv) continue;
        const int u = int(uv->x() + 0.5), v = int(uv->y() + 0.5);
        // Hidden behind a nearer surface the pixel shows that surface (a wall in front of the
        // ground); without this test the "closest camera" rule would even keep that colour.
        if (!view.unoccluded(u, v, depth)) continue;
        const uint8_t* px = image.at(u, v);
        uint8_t* tx = t.texture.at(b, a);
        for (int c = 0; c < 3; ++c) tx[c] = px[image.channels >= 3 ? c : 0];
        t.texel_range[tk] = range;
        ++updated;
      }
    }
  }
  return updated;
}

std::size_t TerrainMesh::verticesWithData() const {
  std::size_t n = 0;
  forEachVertex([&](const Tile&, int, const VertexKey&) { ++n; });
  return n;
}

std::size_t TerrainMesh::texturedVertices() const {
  std::size_t n = 0;
  const int tpc = p_.texels_per_cell, T = textureSize();
  forEachVertex([&](const Tile& t, int k, const VertexKey&) {
    const int i = k / t.n, j = k % t.n;
    if (std::isfinite(t.texel_range[std::size_t(i * tpc) * T + j * tpc])) ++n;
  });
  return n;
}

}  // namespace terramrf::meshing
