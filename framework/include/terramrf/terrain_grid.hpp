#pragma once
// The 2D terrain grid of paper 000 §4.1: square cells on the x/y plane of a frame, a set of named
// float layers (NaN = no data, as grid_map does) and one label layer.
#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "terramrf/cell_pixels.hpp"
#include "terramrf/label_set.hpp"
#include "terramrf/point_cloud.hpp"

namespace terramrf {

struct GridGeometry {
  double size_m = 40.0;  ///< side length of the square grid [m]
  double cell_m = 0.5;   ///< side length of one cell [m]
  /// Centre of the grid in the grid frame [m]; (0,0) = centred on the sensor.
  Eigen::Vector2d centre_m = Eigen::Vector2d::Zero();

  int cols() const { return static_cast<int>(std::lround(size_m / cell_m)); }
  int rows() const { return cols(); }
  std::size_t cells() const { return std::size_t(rows()) * cols(); }
  /// Lower-left corner (min x, min y) [m].
  Eigen::Vector2d origin() const { return centre_m - Eigen::Vector2d::Constant(0.5 * cols() * cell_m); }
  /// Row-major cell index of (x, y) [m], or -1 outside. Row grows with x (forward), column with y.
  int cellOf(double x, double y) const {
    const Eigen::Vector2d o = origin();
    const double fr = (x - o.x()) / cell_m, fc = (y - o.y()) / cell_m;
    if (!(fr >= 0 && fc >= 0)) return -1;  // also rejects NaN
    const int r = static_cast<int>(fr), c = static_cast<int>(fc);
    if (r >= rows() || c >= cols()) return -1;
    return r * cols() + c;
  }
  /// Centre of a cell [m].
  Eigen::Vector2d cellCentre(int row, int col) const {
    return origin() + Eigen::Vector2d((row + 0.5) * cell_m, (col + 0.5) * cell_m);
  }
};

/// A dense float layer over the grid, row-major, NaN where there is no data.
using Layer = std::vector<float>;

inline constexpr float kNoData = std::numeric_limits<float>::quiet_NaN();

class TerrainGrid {
 public:
  TerrainGrid() = default;
  explicit TerrainGrid(const GridGeometry& g) { reset(g); }

  /// Resets the geometry and clears the labels and point lists, keeping their capacity for the
  /// next frame; drops every layer with its memory (the stages add theirs anew each frame).
  void reset(const GridGeometry& g);
  /// Copies the layers `names` of `from` (a grid received from elsewhere, Frame::grid), and its
  /// label layer if `labels`, over this grid's, leaving its points as they are; nothing else of
  /// `from` is taken. Throws std::invalid_argument naming both geometries if `from`'s rows,
  /// columns, cell size or centre (to 1 µm) differ, and naming the layer if `from` lacks one or
  /// one's size is not the cell count.
  void adoptLayers(const TerrainGrid& from, const std::vector<std::string>& names, bool labels);

  const GridGeometry& geometry() const { return geom_; }
  int rows() const { return rows_; }
  int cols() const { return cols_; }
  std::size_t cells() const { return std::size_t(rows_) * cols_; }
  int index(int r, int c) const { return r * cols_ + c; }

  // ---- named layers -------------------------------------------------------------------------
  bool has(const std::string& name) const { return layers_.count(name) != 0; }
  /// Adds (or resets to NaN) a layer and returns it.
  Layer& add(const std::string& name, float fill = kNoData);
  /// Throws std::out_of_range naming the layer if absent.
  Layer& layer(const std::string& name);
  const Layer& layer(const std::string& name) const;
  std::vector<std::string> layerNames() const;

  // ---- labels ---------------------------------------------------------------------------------
  std::vector<LabelId>& labels() { return labels_; }
  const std::vector<LabelId>& labels() const { return labels_; }

  // ---- points per cell (CSR) -----------------------------------------------------------------
  /// Bins a cloud: fills cell_of_point (-1 outside), offsets and indices. O(N + cells).
  void binPoints(const PointCloud& cloud);
  /// Number of points in a cell.
  uint32_t count(int cell) const { return offsets_[cell + 1] - offsets_[cell]; }
  /// Indices (into the cloud) of the points in a cell: [begin, end).
  const uint32_t* pointsBegin(int cell) const { return indices_.data() + offsets_[cell]; }
  const uint32_t* pointsEnd(int cell) const { return indices_.data() + offsets_[cell + 1]; }
  /// Cell of each point, -1 if outside the grid.
  const std::vector<int32_t>& cellOfPoint() const { return cell_of_point_; }
  std::size_t pointsInside() const { return indices_.size(); }

  /// Lowest, highest and mean z of each cell's points [m, LiDAR frame], NaN where a cell has
  /// none. The mean is summed in double in the cell's point order, as a walk over the cell would.
  struct ZRange {
    std::vector<float> min, max;
    std::vector<double> mean;
  };
  /// The cells' z ranges and means of `cloud`, which must be the cloud last binned, unchanged
  /// since: computed on the first call after binPoints() and then shared, as several stages need
  /// them (height difference, relative height, height above ground and camera fusion each walked
  /// every point for them: ~0.1 ms per walk on a 124k-point scan). Throws std::logic_error if
  /// `cloud` has another size than the binned one.
  const ZRange& zRange(const PointCloud& cloud);

  // ---- pixels per cell, one entry per fused camera (empty until a fusion stage runs) ---------
  std::vector<CellPixels>& cellPixels() { return cell_pixels_; }
  const std::vector<CellPixels>& cellPixels() const { return cell_pixels_; }

 private:
  GridGeometry geom_;
  int rows_ = 0, cols_ = 0;
  std::map<std::string, Layer> layers_;
  std::vector<LabelId> labels_;
  std::vector<uint32_t> offsets_;  // cells + 1
  std::vector<uint32_t> indices_;
  std::vector<int32_t> cell_of_point_;
  std::vector<CellPixels> cell_pixels_;
  ZRange z_range_;
  bool z_range_valid_ = false;
};

}  // namespace terramrf
