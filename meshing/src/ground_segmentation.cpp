#include "terramrf/meshing/ground_segmentation.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "terramrf/errors.hpp"
#include "terramrf/label_set.hpp"

namespace terramrf::meshing {

GroundSegmentation segmentGround(const Image& image, const CameraModel& cam,
                                 const PointCloud& pts, const GroundSegParams& p,
                                 const std::string& name) {
  if (image.channels != 3)
    throw InputError(name, "camera image has " + std::to_string(image.channels) +
                               " channel(s); expected RGB for ground segmentation");
  if (cam.width && cam.height && (cam.width != image.width || cam.height != image.height))
    throw InputError(name, "image is " + std::to_string(image.width) + "x" +
                               std::to_string(image.height) + " px but the camera model says " +
                               std::to_string(cam.width) + "x" + std::to_string(cam.height));
  const int W = image.width, H = image.height;
  // Textured ground (grass, gravel) imaged finer than the LiDAR samples it: single pixels of a
  // grass field are as dark as a bush's shadow or as bright as the sky. The colour model and the
  // contrast of eq. 12 then see the texture's mean colour over a (2k+1)² box (k = 0: raw pixels).
  Image smoothed;
  if (p.colour_smooth_px > 0) {
    smoothed = Image(W, H, 3);
    const int k = 2 * p.colour_smooth_px + 1;
    cv::blur(cv::Mat(H, W, CV_8UC3, const_cast<uint8_t*>(image.data.data())),
             cv::Mat(H, W, CV_8UC3, smoothed.data.data()), cv::Size(k, k), cv::Point(-1, -1),
             cv::BORDER_REFLECT);
  }
  const Image& img = p.colour_smooth_px > 0 ? smoothed : image;
  GroundSegmentation g;
  g.width = W;
  g.height = H;
  std::vector<uint8_t> seed(std::size_t(W) * H, 0);
  ColourModel colours(p.colour_bins, H, p.colour_band_rows);
  std::vector<uint32_t> lidar_obj;  // pixels of non-ground points
  // Eq. 7: t = K R [I | −C] T, here P · T_camera_lidar (CameraModel::projectUnbounded). Every
  // point is projected once; its pixel (or −1) is kept for the passes below.
  const Eigen::Matrix3d R = cam.T_camera_lidar.linear();
  const Eigen::Vector3d tr = cam.T_camera_lidar.translation();
  const bool plain = cam.distortion == std::array<double, 5>{0, 0, 0, 0, 0};
  thread_local std::vector<int32_t> pix;
  pix.assign(pts.size(), -1);
  double xmin = 1e30, xmax = -1e30, ymin = 1e30, ymax = -1e30;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const Eigen::Vector3d pl(pts.x[i], pts.y[i], pts.z[i]);
    double uf, vf;
    if (plain) {
      const Eigen::Vector3d pc = R * pl + tr;
      if (pc.z() <= 1e-6) continue;
      const Eigen::Vector3d q = cam.P * pc.homogeneous();
      uf = q.x() / q.z();
      vf = q.y() / q.z();
    } else {
      const auto uv = cam.projectUnbounded(pl);
      if (!uv) continue;
      uf = uv->x();
      vf = uv->y();
    }
    const int u = int(std::floor(uf + 0.5)), v = int(std::floor(vf + 0.5));
    if (u < 0 || v < 0 || u >= W || v >= H) continue;
    pix[i] = v * W + u;
    xmin = std::min(xmin, double(pts.x[i]));
    xmax = std::max(xmax, double(pts.x[i]));
    ymin = std::min(ymin, double(pts.y[i]));
    ymax = std::max(ymax, double(pts.y[i]));
  }
  // Column cells (seed_cell_m, aligned to multiples of it) over the points in view plus one
  // neighbourhood: lowest/highest point per cell, and the lowest/highest over the (2·nb+1)²
  // neighbourhood, for local (slope-independent) object and ditch tests. They cover the whole
  // view up to kMaxReachM: ground beyond them could only be seeded by the flat-world band, and
  // far-field grass on a hill, up to the horizon, would be lost (a fixed 60 m reach was the main
  // cause of missed ground). Buffers are reused between calls (no page faults per image).
  constexpr double kMaxReachM = 200.0;
  const double cs = p.seed_cell_m;
  const int nb = std::max(1, int(std::lround(p.neighbourhood_m / cs)));
  if (xmin > xmax) xmin = xmax = ymin = ymax = 0;
  xmin = std::max(xmin, -kMaxReachM);
  xmax = std::min(xmax, kMaxReachM);
  ymin = std::max(ymin, -kMaxReachM);
  ymax = std::min(ymax, kMaxReachM);
  const int r0 = int(std::floor(xmin / cs)) - nb - 1, c0 = int(std::floor(ymin / cs)) - nb - 1;
  const int nr = std::max(1, int(std::floor(xmax / cs)) + nb + 2 - r0);
  const int ncol = std::max(1, int(std::floor(ymax / cs)) + nb + 2 - c0);
  const std::size_t ncell = std::size_t(nr) * ncol;
  thread_local std::vector<float> zlo, zhi, zlo_ref, nlo, nhi, nlo_obj, tmp;
  thread_local std::vector<int32_t> cell_of;
  zlo.assign(ncell, 1e9f);
  zhi.assign(ncell, -1e9f);
  cell_of.resize(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const double fr = std::floor(pts.x[i] / cs) - r0, fc = std::floor(pts.y[i] / cs) - c0;
    const bool in = fr >= 0 && fc >= 0 && fr < nr && fc < ncol;
    const int c = cell_of[i] = in ? int(fr) * ncol + int(fc) : -1;
    if (c < 0) continue;
    zlo[c] = std::min(zlo[c], pts.z[i]);
    zhi[c] = std::max(zhi[c], pts.z[i]);
  }
  auto filter = [&](const std::vector<float>& in, bool take_min, std::vector<float>& out) {
    tmp.resize(ncell);
    out.resize(ncell);
    auto pick = [&](float a, float b) { return take_min ? std::min(a, b) : std::max(a, b); };
    for (int r = 0; r < nr; ++r)
      for (int c = 0; c < ncol; ++c) {
        float m = in[r * ncol + c];
        for (int k = std::max(0, c - nb); k <= std::min(ncol - 1, c + nb); ++k)
          m = pick(m, in[r * ncol + k]);
        tmp[r * ncol + c] = m;
      }
    for (int r = 0; r < nr; ++r)
      for (int c = 0; c < ncol; ++c) {
        float m = tmp[r * ncol + c];
        for (int k = std::max(0, r - nb); k <= std::min(nr - 1, r + nb); ++k)
          m = pick(m, tmp[k * ncol + c]);
        out[r * ncol + c] = m;
      }
  };
  filter(zlo, true, nlo);
  filter(zhi, false, nhi);
  // h1 of the paper is the ground plane z = −h1 below the sensor. A vehicle pitched on a slope,
  // or a sensor whose mount height is not known exactly, puts the real ground plane elsewhere
  // (RELLIS 000104: ground at z = −1.25 m at 5 m, −0.6 m at 17 m). Fit it to the local minima of
  // the cells (the ground under grass and beside bushes), starting from z = −h1 and then
  // tightening the acceptance to the band; fall back to z = −h1 when the fit is poorly supported.
  Eigen::Vector3d plane(0, 0, -p.sensor_height_m);  // z = a·x + b·y + c
  if (p.fit_ground_plane) {
    const double rmax2 = p.plane_fit_range_m * p.plane_fit_range_m;
    Eigen::Vector3d est = plane;
    bool ok = true;
    for (int it = 0; it < 4 && ok; ++it) {
      Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
      Eigen::Vector3d b = Eigen::Vector3d::Zero();
      std::size_t n = 0;
      for (int r = 0; r < nr; ++r) {
        const double x = (r0 + r + 0.5) * cs;
        for (int c = 0; c < ncol; ++c) {
          const int k = r * ncol + c;
          if (zlo[k] > 1e8f || zlo[k] > nlo[k] + 0.05f) continue;  // empty, or not a local minimum
          const double y = (c0 + c + 0.5) * cs, d2 = x * x + y * y;
          if (d2 > rmax2) continue;
          const double res = zlo[k] - (est.x() * x + est.y() * y + est.z());
          const double tol = it == 0 ? p.band_m + p.local_max_slope * std::sqrt(d2) : p.band_m;
          if (std::abs(res) > tol) continue;
          const Eigen::Vector3d q(x, y, 1.0);
          A += q * q.transpose();
          b += q * double(zlo[k]);
          ++n;
        }
      }
      ok = n >= 30 && std::abs(A.determinant()) > 1e-9;
      if (ok) est = A.ldlt().solve(b);
    }
    if (ok && std::hypot(est.x(), est.y()) <= p.plane_max_slope &&
        std::abs(est.z() + p.sensor_height_m) <= p.plane_max_offset_m) {
      plane = est;
      g.plane_fitted = true;
    }
  }
  g.ground_plane = {plane.x(), plane.y(), plane.z()};
  auto groundZ = [&](double x, double y) { return plane.x() * x + plane.y() * y + plane.z(); };
  const double below_r2 = p.below_sample_range_m * p.below_sample_range_m;
  // The object test measures height above the lowest point around, but a ditch floor is no
  // ground level: the grass on its rim would stand "above" it and become a non-ground sample
  // (a strip of missed ground along every ditch). Within the ditch-sampling range, cells below
  // the band count as at its bottom for this reference.
  zlo_ref = zlo;
  for (int r = 0; r < nr; ++r) {
    const double x = (r0 + r + 0.5) * cs;
    if (std::abs(x) > p.below_sample_range_m) continue;
    for (int c = 0; c < ncol; ++c) {
      const double y = (c0 + c + 0.5) * cs;
      float& z = zlo_ref[r * ncol + c];
      if (x * x + y * y < below_r2) z = std::max(z, float(groundZ(x, y) - p.band_m));
    }
  }
  filter(zlo_ref, true, nlo_obj);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (pix[i] < 0) continue;
    const double z = pts.z[i];
    const double r2 = double(pts.x[i]) * pts.x[i] + double(pts.y[i]) * pts.y[i];
    const int cell = cell_of[i];
    // Band around the ground plane (the paper's −h1 ± Δ when the plane is not fitted).
    const double gz = groundZ(pts.x[i], pts.y[i]);
    const double lo = gz - p.band_m, hi = gz + p.band_m, obj = hi + p.object_above_m;
    // Object: clearly above the lowest point around it. Ditch: clearly below the highest point
    // around it and below the band. Both give non-ground colour samples.
    // An object has height within its own cell (a wall, a crown, a car's side), or stands far
    // above everything around it; flat ground beside a ditch is above the ditch floor but flat.
    const bool is_obj = cell >= 0 ? (z - nlo_obj[cell] >= p.object_above_m &&
                                     (zhi[cell] - zlo[cell] >= p.seed_max_step_m ||
                                      (z - nlo_obj[cell] >= 1.5 && z > hi + 1.0)))
                                  : z >= obj;
    const bool below = z < lo - 0.1 && r2 < below_r2 && cell >= 0 && nhi[cell] - z >= p.object_above_m;
    bool in_band = z >= lo && z <= hi && !is_obj;
    // Hills: the flat-world band misses ground that rises or falls away from the vehicle; a
    // point at the bottom of a flat neighbourhood is ground as well.
    if (!in_band && p.local_seeds && cell >= 0 && !is_obj && z - nlo[cell] < 0.5 * p.band_m &&
        nhi[cell] - nlo[cell] < p.local_relief_m &&
        std::abs(z - gz) <= p.band_m + p.local_max_slope * std::sqrt(r2))
      in_band = true;
    if (!in_band && !is_obj && !below) continue;
    const int u = pix[i] % W, v = pix[i] / W;
    ++g.projected_points;
    const std::size_t s = std::size_t(v) * W + u;
    if (in_band) {
      const bool flat = cell < 0 || zhi[cell] - zlo[cell] < p.seed_max_step_m;
      if (!flat) continue;
      if (!seed[s]) {
        seed[s] = 1;
        ++g.seeds;
      }
      colours.add(&img.data[s * 3], true, v);
    } else {
      colours.add(&img.data[s * 3], false, v);
      ++g.object_samples;
      lidar_obj.push_back(uint32_t(s));
    }
  }
  if (g.projected_points == 0)
    throw InputError(name, "no LiDAR point projects into the camera image (does the camera pose "
                           "look away from the scan?); expected part of the scan in view");
  colours.finish();
  std::vector<uint8_t> observed = colours.classify(img);
  // Where the LiDAR saw the pixel, its geometry is the observation (eq. 10); colour elsewhere.
  const int rad = p.lidar_observation_px;
  auto paint = [&](std::size_t s, uint8_t val) {
    const int u = int(s % W), v = int(s / W);
    for (int dv = -rad; dv <= rad; ++dv)
      for (int du = -rad; du <= rad; ++du) {
        const int uu = u + du, vv = v + dv;
        if (uu >= 0 && vv >= 0 && uu < W && vv < H) observed[std::size_t(vv) * W + uu] = val;
      }
  };
  for (std::size_t s = 0; s < seed.size(); ++s)
    if (seed[s]) paint(s, 1);
  for (uint32_t s : lidar_obj) paint(s, 0);
  // Between two ground returns of neighbouring beams in one image column there is ground: fill
  // the gap (lane markings and other ground texture the colour model calls non-ground).
  if (p.column_fill_px > 0) {
    std::vector<int8_t> cls(seed.size(), -1);
    // A return covers column_fill_halfwidth_px columns either side: with a LiDAR sparser than the
    // image across (RELLIS: a return every ~9 px) most columns hold no return at all.
    const int hw = p.column_fill_halfwidth_px;
    auto mark = [&](std::size_t s, int8_t c) {
      const int u = int(s % W), v = int(s / W);
      for (int uu = std::max(0, u - hw); uu <= std::min(W - 1, u + hw); ++uu) {
        int8_t& x = cls[std::size_t(v) * W + uu];
        if (uu == u || x < 0 || c == 0) x = c;  // an object return wins a shared column
      }
    };
    for (std::size_t s = 0; s < seed.size(); ++s)
      if (seed[s]) mark(s, 1);
    for (uint32_t s : lidar_obj) mark(s, 0);
    for (int u = 0; u < W; ++u) {
      int last_v = -1, last_c = -1;
      for (int v = 0; v < H; ++v) {
        const int c = cls[std::size_t(v) * W + u];
        if (c < 0) continue;
        if (c == 1 && last_c == 1 && v - last_v <= p.column_fill_px)
          for (int k = last_v + 1; k < v; ++k) observed[std::size_t(k) * W + u] = 1;
        last_v = v;
        last_c = c;
      }
    }
  }
  PixelMrfResult r = solvePixelMrf(img, seed, observed, {}, p.mrf);
  g.ground = std::move(r.label);
  g.evaluated = r.evaluated;
  g.sweeps = r.sweeps;
  g.seed = std::move(seed);
  g.observed = std::move(observed);
  return g;
}

GroundConfusion compareGround(const GroundSegmentation& seg, const Image& truth,
                              const std::string& truth_name) {
  GroundConfusion c;
  if (truth.width != seg.width || truth.height != seg.height || truth.channels != 1)
    throw InputError(truth_name, "is " + std::to_string(truth.width) + "x" +
                                     std::to_string(truth.height) + " px with " +
                                     std::to_string(truth.channels) + " channel(s); expected " +
                                     std::to_string(seg.width) + "x" + std::to_string(seg.height) +
                                     " px with 1 channel (the segmented image's size, label ids)");
  const std::size_t N = std::size_t(seg.width) * seg.height;
  for (std::size_t s = 0; s < N; ++s) {
    const LabelId t = truth.data[s];
    const bool tg = t == labels::kRoad || t == labels::kRough;
    const bool pg = seg.ground[s] != 0;
    if (tg) (pg ? c.tp : c.fn)++;
    else (pg ? c.fp : c.tn)++;
  }
  return c;
}

}  // namespace terramrf::meshing
