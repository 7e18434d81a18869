#pragma once
// Grid-based textured terrain mesh of paper 004 §3.1: square tiles of n × n vertices (151 × 151,
// 0.125 m apart in the paper) in the world frame, created on demand when a registered point falls
// outside the existing tiles (a point belongs to the tile with x ∈ [ti·L, (ti+1)·L), y likewise;
// its nearest vertex may be that tile's far border, which it shares with the next tile). Each
// vertex keeps the elevation statistics of the points registered on it, its class (§3.2–3.4) and
// the recovered height (§3.3); each tile keeps a texture baked from the camera images, so a
// vertex's texture coordinate is fixed by its place in the tile.
//
// Neighbouring tiles share their border row/column of vertices and texels (a point on a border
// updates every existing copy; a new tile copies them from its neighbours), so every tile is a
// self-contained mesh and the tiles join without gaps or texture seams.
#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "terramrf/camera.hpp"
#include "terramrf/image.hpp"
#include "terramrf/meshing/camera_view.hpp"
#include "terramrf/point_cloud.hpp"

namespace terramrf::meshing {

/// Class of a mesh vertex. Ground / object come from the image segmentation (§3.2); objects are
/// split into building / tree by the masking method (§3.4).
enum class VertexClass : uint8_t {
  kUnknown = 0,  ///< no data, or never seen by a camera
  kGround = 1,
  kObject = 2,   ///< non-ground, not (yet) split
  kTree = 3,     ///< trees and every other non-building object (paper: "tree objects")
  kBuilding = 4,
};
const char* toString(VertexClass c);

struct TerrainMeshParams {
  int tile_vertices = 151;  ///< vertices per tile side (paper: 151)
  double cell_m = 0.125;    ///< vertex spacing [m] (paper: 0.125)
  int texels_per_cell = 2;  ///< texture resolution: texels per cell side [1]
};

/// Largest tile a TerrainMesh accepts [bytes]: 256 MiB. Every tile is allocated whole (vertex
/// arrays and texture) as soon as a point falls in it, and a drive makes many; at the parameter
/// bounds of the textured_mesh output (2001 vertices, 8 texels per cell) one tile took 1.7 GiB.
inline constexpr double kMaxTileBytes = 256.0 * 1024 * 1024;

/// Memory one tile of these parameters takes [bytes]: n² vertices of the Tile's per-vertex
/// arrays plus the T × T texture (RGB) and its texel ranges, T = (n − 1)·texels_per_cell + 1.
/// In double, so parameters far out of range cannot overflow it.
double tileBytes(const TerrainMeshParams& p);

/// Why tiles of these parameters are too large (above kMaxTileBytes), naming tile_vertices,
/// texels_per_cell and the estimate; empty when they fit.
std::string tileBudgetProblem(const TerrainMeshParams& p);

/// One tile: n × n vertices, row index along world x, column index along world y.
struct Tile {
  int ti = 0, tj = 0;  ///< tile index: covers x ∈ [ti·L, (ti+1)·L], L = (n−1)·cell
  int n = 0;           ///< vertices per side
  // Per vertex, row-major (i·n + j).
  std::vector<float> z_max;      ///< highest registered point [m], NaN = no data
  std::vector<float> z_min;      ///< lowest registered point [m]
  // The sums are double: with world-frame heights (z ≈ 300 m) a float sum of 60 000 points on one
  // vertex (a vehicle standing still) rounded its mean 0.17 m low. 12 bytes more per vertex than
  // float (then 49 instead of 37 bytes per vertex; now 53 with 32-bit votes: 1.76 MiB per tile of
  // 151² vertices, 2 texels/cell).
  std::vector<double> z_sum;     ///< sum of heights (mean = z_sum / count) [m]
  std::vector<uint32_t> count;   ///< registered points
  // 32-bit: 16-bit counts saturated at 65 535 images of one vertex (a vehicle standing an hour
  // or more in view), after which both tied and the vertex fell to ground whatever it was.
  std::vector<uint32_t> ground_votes, object_votes;  ///< per-image segmentation votes
  std::vector<double> rec_sum;     ///< Σ weight·height of the recovered-height estimates [m]
  std::vector<double> rec_weight;  ///< Σ weight of those estimates (1/range⁴) [m⁻⁴]
  std::vector<float> rec_lower;            ///< lower bound when the top left the image [m]
  std::vector<VertexClass> cls;
  std::vector<float> mask_response;        ///< U of eq. 13 (normalised if configured), NaN = none
  // Texture: T × T RGB, T = (n − 1)·texels_per_cell + 1; texel (a, b) ↔ world
  // (x0 + a·cell/tpc, y0 + b·cell/tpc), stored with image row = a, column = b.
  Image texture;
  std::vector<float> texel_range;  ///< camera distance of the texel's colour [m], inf = none

  std::size_t vertices() const { return std::size_t(n) * n; }
  bool hasData(int k) const { return count[k] > 0; }
};

/// Key of a vertex in the global lattice: (round(x / cell), round(y / cell)).
using VertexKey = std::pair<int64_t, int64_t>;

class TerrainMesh {
 public:
  explicit TerrainMesh(const TerrainMeshParams& p = {});

  const TerrainMeshParams& params() const { return p_; }
  int tileSpan() const { return p_.tile_vertices - 1; }  ///< cells per tile side
  int textureSize() const { return tileSpan() * p_.texels_per_cell + 1; }

  /// Registers one world point [m] on its nearest vertex (every existing copy of it). Creates the
  /// point's tile only when it does not exist yet, i.e. when the point lies outside every tile.
  void addPoint(const Eigen::Vector3d& p_world);
  /// Registers a cloud given in the LiDAR frame with pose T_world_lidar; points farther than
  /// max_range_m from the sensor (horizontally) are skipped and counted in the return value.
  std::size_t addCloud(const PointCloud& cloud, const Eigen::Isometry3d& T_world_lidar,
                       double max_range_m);
  /// Adds one recovered-height estimate z_m [m] with weight `weight` (> 0) to every copy of the
  /// vertex `key` (§3.3); displayHeight uses their weighted mean.
  void addHeightEstimate(const VertexKey& key, double z_m, double weight);

  const std::map<std::pair<int, int>, std::unique_ptr<Tile>>& tiles() const { return tiles_; }
  std::map<std::pair<int, int>, std::unique_ptr<Tile>>& tiles() { return tiles_; }
  std::size_t tileCount() const { return tiles_.size(); }
  const Tile* tile(int ti, int tj) const;

  /// World position of vertex (i, j) of a tile [m] (z: display elevation, NaN without data).
  Eigen::Vector3d vertexPosition(const Tile& t, int i, int j) const;
  /// Elevation shown in the exports [m]: for objects the highest of the LiDAR max, the recovered
  /// estimate and the recovered lower bound (an estimate below a measured bound is wrong); the
  /// mean for ground/unknown vertices. NaN without data.
  float displayHeight(const Tile& t, int k) const;
  /// Texture coordinate in [0, 1]² of vertex (i, j) (u along the texture's columns = y).
  Eigen::Vector2f vertexUv(int i, int j) const;

  /// Calls f(tile, k, global key) for every vertex with data, each global vertex once (the
  /// owning tile is the one where the vertex is not on the far border row/column).
  template <class F>
  void forEachVertex(F&& f) const;
  /// True when `t` is the tile that reports its vertex (i, j) (see forEachVertex): loops over
  /// tiles that must handle each global vertex once test this.
  bool owns(const Tile& t, int i, int j) const {
    const int span = tileSpan();
    if (i < span && j < span) return true;
    return ownerOf(int64_t(t.ti) * span + i, int64_t(t.tj) * span + j) == &t;
  }

  /// Copy of value `apply` to the same global vertex in every tile holding it.
  template <class F>
  void forEachCopy(const VertexKey& key, F&& f);

  /// Bakes texture from one camera image: each texel with a known elevation that projects into
  /// the image and is visible there (no LiDAR surface of the view clearly nearer: ground behind a
  /// wall must not take the wall's colour) takes the pixel colour when the camera is closer than
  /// the texel's previous source. `image` must have the view's size (std::invalid_argument
  /// otherwise). Returns the number of texels updated.
  std::size_t bakeTexture(const CameraView& view, const Image& image, double max_range_m);

  std::size_t verticesWithData() const;
  std::size_t texturedVertices() const;  ///< vertices with data whose texel got a colour

 private:
  Tile& ensureTile(int ti, int tj);
  void tileOf(int64_t gi, int64_t gj, int& ti, int& tj) const;
  /// The tile that reports a shared vertex: tileOf(v) if it exists, else (ti, tj−1), (ti−1, tj),
  /// (ti−1, tj−1), the first that exists.
  const Tile* ownerOf(int64_t gi, int64_t gj) const;

  TerrainMeshParams p_;
  std::map<std::pair<int, int>, std::unique_ptr<Tile>> tiles_;
};

// ---- implementation ------------------------------------------------------------------------

inline int64_t floorDiv(int64_t a, int64_t b) {
  const int64_t q = a / b;
  return (a % b != 0 && ((a < 0) != (b < 0))) ? q - 1 : q;
}

template <class F>
void TerrainMesh::forEachVertex(F&& f) const {
  const int span = tileSpan();
  for (const auto& [key, tp] : tiles_) {
    const Tile& t = *tp;
    for (int i = 0; i < span; ++i) {
      for (int j = 0; j < span; ++j) {
        const int k = i * t.n + j;
        if (!t.hasData(k)) continue;
        f(t, k, VertexKey{int64_t(t.ti) * span + i, int64_t(t.tj) * span + j});
      }
    }
    // Border vertices shared with neighbours: emitted by the first existing tile of the
    // order tileOf(v), then the tiles before it (see ownerOf).
    for (int i = 0; i < t.n; ++i) {
      for (int j = 0; j < t.n; ++j) {
        if (i < span && j < span) continue;
        const int k = i * t.n + j;
        if (!t.hasData(k)) continue;
        const int64_t gi = int64_t(t.ti) * span + i, gj = int64_t(t.tj) * span + j;
        if (ownerOf(gi, gj) == &t) f(t, k, VertexKey{gi, gj});
      }
    }
  }
}

template <class F>
void TerrainMesh::forEachCopy(const VertexKey& key, F&& f) {
  const int span = tileSpan();
  int ti, tj;
  tileOf(key.first, key.second, ti, tj);
  for (int di = 0; di >= -1; --di) {
    for (int dj = 0; dj >= -1; --dj) {
      auto it = tiles_.find({ti + di, tj + dj});
      if (it == tiles_.end()) continue;
      Tile& t = *it->second;
      const int64_t i = key.first - int64_t(t.ti) * span, j = key.second - int64_t(t.tj) * span;
      if (i < 0 || j < 0 || i >= t.n || j >= t.n) continue;
      f(t, int(i * t.n + j));
    }
  }
}

}  // namespace terramrf::meshing
