// Camera–LiDAR fusion (paper 000 §4.5): a per-scan lookup point → pixel, and for every grid cell
// the set of pixels it covers, for each camera of the frame. Image features (haralick,
// homogeneity, colour) read the result from TerrainGrid::cellPixels().
//
// Cell pixels: the cell's square footprint is put at one height (the mean or the lowest z of its
// points), its 4 corners are projected with CameraModel::projectUnbounded and the pixels whose
// centres fall inside the projected quadrilateral are taken (clipped to the image). The footprint
// is the natural support of a cell-wise texture feature; the points alone cover only a few
// pixels per ring crossing. Where the footprint gives nothing (a corner behind the camera or
// beyond the distortion's fold, where projectUnbounded gives none; a far cell thinner than a pixel
// row; every pixel occluded), the points' own pixels are used instead (`point_pixels`).
//
// Occlusion (`occlusion: depth_test`): the footprint says where the cell would be in the image,
// not whether the camera sees it; a ground cell behind a car or a wall would take the car's or
// the wall's pixels. The per-point lookup gives a sparse z-buffer (OcclusionBuffer: nearest point
// and its cell per pixel, splatted over a few pixels to bridge the gaps between rings), and a
// footprint pixel is dropped where a point of another cell is nearer than the footprint plane
// there by more than `occlusion_margin` (a point pixel: nearer than that point). Pixels no point
// reaches are kept: nothing is known to be in front of them. Dropped pixels are counted
// (metrics `occluded_pixels`, `occluded_cells`, `hidden_cells`).
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "footprint_raster.hpp"
#include "occlusion_buffer.hpp"
#include "pinhole_projection.hpp"
#include "ring_gap.hpp"
#include "terramrf/plugin.hpp"

namespace terramrf {

class CameraFusion final : public Stage {
 public:
  void declare(ParamDecl& d) override {
    d.add("cameras", cameras_, "names of the cameras to fuse (CameraModel::name); empty = all")
        .unique();
    d.add("footprint_height", footprint_height_,
          "height of the projected cell square: mean or lowest z of the cell's points")
        .choices({"mean", "min"});
    d.add("point_pixels", point_pixels_,
          "use of the points' own pixels: fallback (only where the footprint covers none), "
          "combine (footprint ∪ points), none")
        .choices({"fallback", "combine", "none"});
    d.add("max_pixels_per_cell", max_pixels_,
          "cap on a cell's pixels (the footprint shrinks about "
          "its centre to meet it; bounds the feature cost)")
        .unit("px")
        .range(1, 1 << 22);
    d.add("min_points", min_points_, "cells with fewer points get no pixels")
        .unit("points")
        .range(1, 100000);
    d.add("occlusion", occlusion_,
          "depth_test: drop a cell's pixels where a LiDAR point of another cell is nearer to the "
          "camera (sparse z-buffer of the scan); none: keep every footprint pixel")
        .choices({"depth_test", "none"});
    d.add("occlusion_margin", occlusion_margin_,
          "a pixel is occluded when the nearest point there is nearer than the cell's surface by "
          "more than this fraction of the cell's depth (absorbs the splat and ground relief)")
        .unit("1")
        .range(0.0, 0.9);
    d.add("occlusion_splat_px", occlusion_splat_px_,
          "each point's depth covers the square of this half-width around its pixel, to bridge "
          "the gaps between rings in the image (0 = its own pixel only); with occlusion_splat: "
          "ring_gap, used where the gap cannot be measured")
        .unit("px")
        .range(0, kMaxSplatPx);
    d.add("occlusion_splat", occlusion_splat_,
          "fixed: the half-width is occlusion_splat_px; ring_gap: per frame and camera the "
          "half-width r whose square spans the median vertical gap g between adjacent rings in "
          "the image (2r + 1 = g to the nearest pixel, at most 16 px; metrics ring_gap_px, "
          "splat_px), for sensors much sparser or denser in the image than KITTI's")
        .choices({"fixed", "ring_gap"});
  }
  std::vector<std::string> reads() const override { return {artefacts::kPoints}; }
  std::vector<std::string> writes() const override { return {artefacts::kCellPixels}; }

  void process(FrameContext& ctx) override {
    const Frame& f = *ctx.frame;
    TerrainGrid& g = *ctx.grid;
    const std::string frame_file = f.source_path.empty() ? "frame " + f.id : f.source_path;
    if (f.cameras.empty())
      throw InputError(frame_file, "frame " + f.id +
                                       " has no camera image; camera_fusion needs one (turn on "
                                       "use_images / enable_camera in the source)");
    for (int cam : selectCameras(f, frame_file)) {
      auto& list = g.cellPixels();
      list.erase(std::remove_if(list.begin(), list.end(),
                                [cam](const CellPixels& c) { return c.camera == cam; }),
                 list.end());
      list.push_back(fuse(ctx, cam));
    }
  }

 private:
  std::vector<int> selectCameras(const Frame& f, const std::string& frame_file) const {
    std::vector<int> out;
    if (cameras_.empty()) {
      for (std::size_t i = 0; i < f.cameras.size(); ++i) out.push_back(int(i));
      return out;
    }
    for (const std::string& name : cameras_) {
      int found = -1;
      for (std::size_t i = 0; i < f.cameras.size(); ++i)
        if (f.cameras[i].model.name == name) found = int(i);
      if (found < 0) {
        std::string have;
        for (const auto& c : f.cameras) have += (have.empty() ? "" : ", ") + c.model.name;
        throw InputError(frame_file,
                         "frame " + f.id + " has no camera '" + name + "' (it has: " + have + ")");
      }
      out.push_back(found);
    }
    return out;
  }

  /// Pixel index of projected coordinates (u, v): pixel centres are at integer coordinates, so
  /// the nearest one; a point within half a pixel beyond the last row/column has none.
  static bool store(const CameraModel& m, double u, double v, int32_t* pix) {
    const int iu = int(u + 0.5), iv = int(v + 0.5);  // u, v >= −0.5: the sum is >= 0
    if (iu >= m.width || iv >= m.height) return false;
    *pix = iv * m.width + iu;
    return true;
  }

  static bool isPinhole(const CameraModel& m) {
    return std::all_of(m.distortion.begin(), m.distortion.end(), [](double k) { return k == 0; });
  }

  /// pixel_of_point for the whole scan (−1 where not visible); returns the number of visible
  /// points. Same maths as CameraModel::project (which handles distortion); without distortion P
  /// and T_camera_lidar are pre-multiplied so a point costs one 3×4 product, in a loop without
  /// branches that runs four points per AVX2 vector (pinhole_projection.hpp). With `depth`, also
  /// each visible point's depth w = row 3 of M · [X; 1], the quantity the footprint plane's depth
  /// is compared with (0 where not visible).
  static std::size_t projectScan(const CameraModel& m, const Eigen::Matrix<double, 3, 4>& M,
                                 const PointCloud& pc, int32_t* pix, float* depth) {
    const std::size_t n = pc.size();
    if (isPinhole(m)) {
      PinholeScan s;
      s.x = pc.x.data(), s.y = pc.y.data(), s.z = pc.z.data(), s.n = n;
      const Eigen::Matrix<double, 1, 4> zc = m.T_camera_lidar.matrix().row(2);
      for (int j = 0; j < 4; ++j) {
        s.zc[j] = zc(j);
        for (int r = 0; r < 3; ++r) s.M[r][j] = M(r, j);
      }
      s.width = m.width, s.height = m.height;
      s.pix = pix, s.depth = depth;
      return projectPinhole(s);
    }
    std::size_t visible = 0;
    for (std::size_t i = 0; i < n; ++i) {
      pix[i] = -1;
      if (depth) depth[i] = 0.f;
      const auto uv = m.project(Eigen::Vector3d(pc.x[i], pc.y[i], pc.z[i]));
      if (uv && store(m, uv->x(), uv->y(), &pix[i])) {
        ++visible;
        if (depth)
          depth[i] = float(M(2, 0) * pc.x[i] + M(2, 1) * pc.y[i] + M(2, 2) * pc.z[i] + M(2, 3));
      }
    }
    return visible;
  }

  CellPixels fuse(FrameContext& ctx, int cam_index) {
    const Frame& f = *ctx.frame;
    TerrainGrid& g = *ctx.grid;
    const CameraImage& cam = f.cameras[cam_index];
    const CameraModel& m = cam.model;
    const std::string file = cam.source_path.empty() ? "frame " + f.id : cam.source_path;
    const std::string cam_name = m.name.empty() ? "camera" + std::to_string(cam_index) : m.name;
    if (!cam.image || cam.image->empty())
      throw InputError(file, "camera '" + cam_name + "' of frame " + f.id +
                                 " has no image; camera_fusion needs the image the features read");
    const Image& img = *cam.image;
    // The dataset's names for the calibration (file and entries), else the model's own.
    const std::string calib = m.calibration.empty() ? "P and T_camera_lidar" : m.calibration;
    if (m.width <= 0 || m.height <= 0 || img.width != m.width || img.height != m.height)
      throw InputError(
          file, "image is " + std::to_string(img.width) + "x" + std::to_string(img.height) +
                    " px but the calibration of camera '" + cam_name + "' (" + calib + ") is for " +
                    std::to_string(m.width) + "x" + std::to_string(m.height) + " px");

    CellPixels out;
    out.camera = cam_index;
    out.width = m.width;
    out.height = m.height;

    // Per-scan lookup point → pixel.
    const PointCloud& pc = f.points;
    const std::size_t n = pc.size();
    // Depth test: z-buffer of the scan (depth w of P · T_camera_lidar · [X; 1], as the plane's).
    const bool depth_test = occlusion_ == "depth_test";
    const Eigen::Matrix<double, 3, 4> M = m.P * m.T_camera_lidar.matrix();
    const bool pinhole = isPinhole(m);
    out.pixel_of_point.resize(n);
    if (depth_test) depth_.resize(n);
    const std::size_t visible =
        projectScan(m, M, pc, out.pixel_of_point.data(), depth_test ? depth_.data() : nullptr);
    if (n > 0 && visible == 0)
      throw InputError(file, "the calibration of camera '" + cam_name + "' (" + calib +
                                 ") projects none of the " + std::to_string(n) +
                                 " points of frame " + f.id + " into the " +
                                 std::to_string(m.width) + "x" + std::to_string(m.height) +
                                 " px image (all behind the camera or outside it); check that "
                                 "calibration, and that it belongs to this scan and image");

    const double keep_ratio = 1.0 - occlusion_margin_;
    int splat_px = occlusion_splat_px_;
    double ring_gap_px = std::numeric_limits<double>::quiet_NaN();
    if (depth_test && occlusion_splat_ == "ring_gap") {
      // Every 3rd point, in 64 px bands: still several points of every ring per band on
      // RELLIS-3D (9 px along a ring, 27 between points read); at least 50 gaps for a median
      // (KITTI's image gives ~700, RELLIS-3D's ~600).
      ring_gap_px = medianRingGapPx(out.pixel_of_point, pc.ring, m.width, 64, 50, gap_scratch_, 3);
      if (!std::isnan(ring_gap_px)) splat_px = splatForGap(ring_gap_px, kMaxSplatPx);
    }
    if (depth_test)
      zbuf_.build(m.width, m.height, splat_px, out.pixel_of_point, depth_, g.cellOfPoint());
    std::size_t occluded_pixels = 0, occluded_cells = 0, hidden_cells = 0;
    const uint32_t W = uint32_t(m.width);

    // Pixels per cell (CSR).
    const GridGeometry& geom = g.geometry();
    const Eigen::Vector2d o = geom.origin();
    const double cell_m = geom.cell_m;
    const int cells = int(g.cells());
    out.offsets.assign(std::size_t(cells) + 1, 0);
    // Sized from the last frame: growing by doubling would touch (and page-fault) ~3× the memory.
    out.pixels.reserve(last_pixels_ + last_pixels_ / 4 + 1024);
    std::size_t footprint_cells = 0, fallback_cells = 0, capped_cells = 0;
    const bool use_min = footprint_height_ == "min";
    const std::size_t cap = std::size_t(max_pixels_);
    // Shared with the height features (computed once per binning), and which cells hold a point
    // the camera sees: the points' own pixels are looked for only there, so the cells behind the
    // camera (most of a 360° scan) cost no walk over their points.
    const TerrainGrid::ZRange& zr = g.zRange(pc);
    const std::vector<int32_t>& cell_of_point = g.cellOfPoint();
    seen_.assign(std::size_t(cells), 0);
    for (std::size_t i = 0; i < n; ++i)
      if (out.pixel_of_point[i] >= 0 && cell_of_point[i] >= 0) seen_[cell_of_point[i]] = 1;
    for (int c = 0; c < cells; ++c) {
      out.offsets[c] = uint32_t(out.pixels.size());
      if (g.count(c) < uint32_t(min_points_) || g.count(c) == 0) continue;
      const double h = use_min ? double(zr.min[c]) : zr.mean[c];
      const int r = c / g.cols(), col = c % g.cols();
      const double x0 = o.x() + r * cell_m, y0 = o.y() + col * cell_m;
      // Corners in order around the square, so the projected polygon is simple.
      const Eigen::Vector3d corners[4] = {
          {x0, y0, h}, {x0 + cell_m, y0, h}, {x0 + cell_m, y0 + cell_m, h}, {x0, y0 + cell_m, h}};
      poly_.clear();
      for (const auto& p : corners) {
        const auto uv = m.projectUnbounded(p);
        if (!uv) break;
        poly_.push_back(*uv);
      }
      const std::size_t begin = out.pixels.size();
      std::size_t got = 0, dropped = 0;
      bool shrunk = false;
      if (poly_.size() == 4) {
        got = raster_.rasterise(poly_, m.width, m.height, cap, out.pixels, &shrunk);
        capped_cells += shrunk;
        footprint_cells += got > 0;
        if (depth_test && got > 0) {
          const Eigen::Vector3d inv =
              pinhole ? planeInverseDepth(M, h) : fitInverseDepth(M, corners);
          std::size_t kept = begin;
          // The pixels come row by row: one division per row for (u, v), not two per pixel.
          uint32_t row_begin = 1, row_end = 0;
          double row_v = 0;  // inv(1)·v on the current row
          for (std::size_t k = begin; k < out.pixels.size(); ++k) {
            const uint32_t p = out.pixels[k];
            float z;
            if (zbuf_.occluder(p, c, &z)) {
              if (p < row_begin || p >= row_end) {
                const uint32_t v = p / W;
                row_begin = v * W, row_end = row_begin + W;
                row_v = inv(1) * double(v);
              }
              const double inv_depth = inv(0) * double(p - row_begin) + row_v + inv(2);
              if (inv_depth > 0 && double(z) * inv_depth < keep_ratio) continue;
            }
            out.pixels[kept++] = p;
          }
          dropped += out.pixels.size() - kept;
          out.pixels.resize(kept);
        }
      }
      const bool footprint_empty = out.pixels.size() == begin;
      const bool add_points = seen_[c] && (point_pixels_ == "combine" ||
                                           (point_pixels_ == "fallback" && footprint_empty));
      bool had_point_pixels = false;
      if (add_points) {
        std::size_t before = out.pixels.size();
        for (const uint32_t* it = g.pointsBegin(c); it != g.pointsEnd(c); ++it) {
          const int32_t p = out.pixel_of_point[*it];
          if (p < 0) continue;
          had_point_pixels = true;
          // The point's own depth: its pixel shows it unless another cell's point is nearer.
          float z;
          if (depth_test && zbuf_.occluder(uint32_t(p), c, &z) &&
              double(z) < keep_ratio * double(depth_[*it])) {
            ++dropped;
            continue;
          }
          out.pixels.push_back(uint32_t(p));
        }
        if (out.pixels.size() > before) {
          const bool capped = capPointPixels(out.pixels, begin, before, cap, m.width);
          capped_cells += capped && !shrunk;
          // Keep the set sorted and unique: features index it as a set of pixels.
          std::sort(out.pixels.begin() + begin, out.pixels.end());
          out.pixels.erase(std::unique(out.pixels.begin() + begin, out.pixels.end()),
                           out.pixels.end());
          fallback_cells += footprint_empty;
        }
      }
      if (dropped > 0) {
        occluded_pixels += dropped;
        ++occluded_cells;
        hidden_cells += out.pixels.size() == begin && (got > 0 || had_point_pixels);
      }
    }
    out.offsets[cells] = uint32_t(out.pixels.size());
    last_pixels_ = out.pixels.size();

    const std::string key = name() + "." + cam_name;  // "<stage>.<what>", as every stage
    ctx.metrics[key + ".visible_points"] = double(visible);
    ctx.metrics[key + ".footprint_cells"] = double(footprint_cells);
    ctx.metrics[key + ".point_pixel_cells"] = double(fallback_cells);
    ctx.metrics[key + ".capped_cells"] = double(capped_cells);
    ctx.metrics[key + ".pixels"] = double(out.pixels.size());
    if (depth_test) {
      ctx.metrics[key + ".occluded_pixels"] = double(occluded_pixels);
      ctx.metrics[key + ".splat_px"] = double(splat_px);
      if (occlusion_splat_ == "ring_gap") ctx.metrics[key + ".ring_gap_px"] = ring_gap_px;
      ctx.metrics[key + ".occluded_cells"] = double(occluded_cells);
      ctx.metrics[key + ".hidden_cells"] = double(hidden_cells);
    }
    return out;
  }

  /// Inverse depth 1/w over the plane z = h as a linear function of the pixel: 1/w = a·u + b·v + c.
  /// H maps plane coordinates (x, y, 1) to (u·w, v·w, w); inverting gives (x, y, 1) = w · H⁻¹ (u,
  /// v, 1), whose last row reads 1 = w · (row 3 of H⁻¹) · (u, v, 1). Exact for a pinhole camera.
  /// `pixels[begin, before)` is a cell's footprint (sorted, at most `cap`), `[before, end)` the
  /// pixels of its points. Drops the point pixels the footprint already has and, past the cap,
  /// those farthest from the cell's centre (the footprint's, or the points' own without one), so
  /// the footprint stays whole: cutting the merged, sorted set at the cap kept its top rows only.
  /// True if the cap removed any.
  static bool capPointPixels(std::vector<uint32_t>& pixels, std::size_t begin, std::size_t before,
                             std::size_t cap, int width) {
    const auto fb = pixels.begin() + begin, fe = pixels.begin() + before;
    std::sort(fe, pixels.end());
    auto end = std::unique(fe, pixels.end());
    end = std::remove_if(fe, end, [&](uint32_t p) { return std::binary_search(fb, fe, p); });
    pixels.erase(end, pixels.end());
    const std::size_t footprint = before - begin;
    const std::size_t room = cap > footprint ? cap - footprint : 0;
    if (pixels.size() - before <= room) return false;
    const auto from = footprint > 0 ? fb : fe;
    const auto to = footprint > 0 ? fe : pixels.end();
    double cu = 0, cv = 0;
    for (auto it = from; it != to; ++it) cu += double(*it % width), cv += double(*it / width);
    cu /= double(to - from), cv /= double(to - from);
    auto dist2 = [&](uint32_t p) {
      const double du = double(p % width) - cu, dv = double(p / width) - cv;
      return du * du + dv * dv;
    };
    std::nth_element(fe, fe + room, pixels.end(),
                     [&](uint32_t a, uint32_t b) { return dist2(a) < dist2(b); });
    pixels.resize(before + room);
    return true;
  }

  static Eigen::Vector3d planeInverseDepth(const Eigen::Matrix<double, 3, 4>& M, double h) {
    const Eigen::Vector3d c0 = M.col(0), c1 = M.col(1), c2 = h * M.col(2) + M.col(3);
    const Eigen::Vector3d r = c0.cross(c1);
    const double det = r.dot(c2);
    if (std::abs(det) < 1e-12 * r.norm() * c2.norm()) return Eigen::Vector3d::Zero();  // edge-on
    return r / det;
  }

  /// With distortion the footprint is rasterised in distorted pixels, where 1/w is no longer
  /// linear: least-squares fit of a·u + b·v + c to 1/w at the 4 projected corners (poly_), about
  /// their centroid. Over one cell the distortion bends the plane's 1/w far less than the margin.
  Eigen::Vector3d fitInverseDepth(const Eigen::Matrix<double, 3, 4>& M,
                                  const Eigen::Vector3d (&corners)[4]) const {
    double iw[4], mu = 0, mv = 0, mi = 0;
    for (int k = 0; k < 4; ++k) {
      iw[k] = 1.0 / (M.row(2).head<3>().dot(corners[k]) + M(2, 3));
      mu += poly_[k].x() / 4, mv += poly_[k].y() / 4, mi += iw[k] / 4;
    }
    double suu = 0, suv = 0, svv = 0, sui = 0, svi = 0;
    for (int k = 0; k < 4; ++k) {
      const double du = poly_[k].x() - mu, dv = poly_[k].y() - mv, di = iw[k] - mi;
      suu += du * du, suv += du * dv, svv += dv * dv, sui += du * di, svi += dv * di;
    }
    const double det = suu * svv - suv * suv;
    double a = 0, b = 0;
    if (det > 1e-9 * (suu * svv + 1e-300)) {
      a = (svv * sui - suv * svi) / det;
      b = (suu * svi - suv * sui) / det;
    }
    return Eigen::Vector3d(a, b, mi - a * mu - b * mv);
  }

  std::vector<std::string> cameras_;
  std::string footprint_height_ = "mean";
  std::string point_pixels_ = "fallback";
  int max_pixels_ = 512;
  int min_points_ = 1;

  std::string occlusion_ = "depth_test";
  double occlusion_margin_ = 0.2;
  int occlusion_splat_px_ = 2;
  std::string occlusion_splat_ = "ring_gap";
  static constexpr int kMaxSplatPx = 16;  // bound of occlusion_splat_px and of the ring_gap splat
  RingGapScratch gap_scratch_;

  FootprintRaster raster_;
  OcclusionBuffer zbuf_;
  std::vector<float> depth_;  // per point [m]; set where visible
  std::vector<uint8_t> seen_;  // per cell: 1 if one of its points has a pixel
  std::size_t last_pixels_ = 0;
  std::vector<Eigen::Vector2d> poly_;
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::CameraFusion, terramrf::PluginKind::kFeature, "camera_fusion",
                "camera–LiDAR fusion: pixel per point and pixels per cell (paper 000 §4.5)")
