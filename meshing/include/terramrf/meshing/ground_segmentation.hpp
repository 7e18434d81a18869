#pragma once
// Ground segmentation in the camera image (paper 004 §3.2): LiDAR points within ±Δ of the ground
// plane below the sensor (z ≈ −h1 in the LiDAR frame) form the rough ground set G1; their pixels
// (eq. 7–8 through CameraModel) are the seeds G1′; a pixel MRF (pixel_mrf.hpp) labels the rest.
// d_s of eq. 10 is a colour class from histograms of the seed pixels (ground) and of the pixels of
// points clearly above the band (non-ground). Optionally (fit_ground_plane) the band surrounds a
// plane fitted to the LiDAR instead of z = −h1 (docs/meshing.md, Deviations).
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "terramrf/camera.hpp"
#include "terramrf/meshing/pixel_mrf.hpp"
#include "terramrf/point_cloud.hpp"

namespace terramrf::meshing {

struct GroundSegParams {
  double sensor_height_m = 1.73;  ///< h1: LiDAR origin above the ground [m]
  double band_m = 0.25;           ///< Δ: half width of the rough ground band [m]
  /// Fit the ground plane z = a·x + b·y + c to the LiDAR (local cell minima within
  /// plane_fit_range_m, starting from z = −h1) and put the band around it instead of z = −h1:
  /// a pitched or rolled vehicle, or an unknown mount height, moves the plane (paper: fixed h1)
  bool fit_ground_plane = false;
  double plane_fit_range_m = 15.0;  ///< the plane is a local approximation near the vehicle [m]
  double plane_max_slope = 0.25;    ///< a steeper fit is rejected (falls back to z = −h1) [1]
  double plane_max_offset_m = 1.0;  ///< so is one whose c is this far from −h1 [m]
  /// Non-ground samples: points this far above the lowest point of their neighbourhood (or below
  /// the highest, for ditches below the band) [m]
  double object_above_m = 0.3;
  double neighbourhood_m = 1.0;   ///< half width of that neighbourhood [m]
  /// Pixels within this distance of a projected point take the point's class as observation d_s
  /// (eq. 10); the colour model decides elsewhere [px]
  int lidar_observation_px = 1;
  /// Pixels between two ground returns at most this far apart in one column are observed ground
  /// (0 = off) [px]
  int column_fill_px = 24;
  /// For that fill a return also stands for this many image columns either side (a LiDAR
  /// sparser than the image across) [px]
  int column_fill_halfwidth_px = 0;
  /// Seeds must also lie in a flat spot: the points of their seed_cell_m × seed_cell_m column
  /// span less than this in height (a car's sill or a wall's foot inside the band is no seed) [m]
  double seed_max_step_m = 0.2;
  double seed_cell_m = 0.5;       ///< [m]
  /// Points below the band within this range are non-ground samples (ditches); within it, the
  /// object test's ground reference ignores ditch floors (the rim is no object) [m]
  double below_sample_range_m = 20.0;
  /// Also seed points at the bottom of a flat neighbourhood outside the band (sloped terrain);
  /// the paper's rough segmentation uses the band only
  bool local_seeds = true;
  double local_relief_m = 0.5;    ///< "flat": highest − lowest point of the neighbourhood [m]
  double local_max_slope = 0.08;  ///< such seeds stay within band + slope·range of the band [1]
  int colour_band_rows = 16;      ///< colour histograms per band of this many rows (0 = one) [px]
  /// Colour observations (d_s of eq. 10, the colour of eq. 12) are box means over
  /// (2k+1)² pixels, k = this; 0 = raw pixels (the paper). For images much finer than the LiDAR
  /// and ground with texture (grass) [px]
  int colour_smooth_px = 0;
  int colour_bins = 16;           ///< histogram bins per RGB channel (8, 16, 32)
  PixelMrfParams mrf;
};

struct GroundSegmentation {
  int width = 0, height = 0;
  std::vector<uint8_t> ground;     ///< per pixel, 1 = ground (G2′)
  std::size_t projected_points = 0;  ///< points (at or above the band) inside the image
  std::size_t seeds = 0;           ///< |G1′| (distinct pixels)
  std::size_t object_samples = 0;
  std::size_t evaluated = 0;       ///< MRF local evaluations
  int sweeps = 0;
  std::array<double, 3> ground_plane{0, 0, 0};  ///< a, b, c of z = a·x + b·y + c (LiDAR frame) [1, 1, m]
  bool plane_fitted = false;                    ///< false: z = −h1 was used
  std::vector<uint8_t> seed;      ///< G1′ per pixel (diagnostics)
  std::vector<uint8_t> observed;  ///< d_s per pixel (diagnostics)
  bool isGround(int u, int v) const { return ground[std::size_t(v) * width + u] != 0; }
};

/// Segments one image. `points` are in the LiDAR frame of `camera.T_camera_lidar`. Throws
/// InputError naming `image_name` when the image is not RGB or its size differs from the model's,
/// and when no point projects into the image (a camera looking away from the scan).
GroundSegmentation segmentGround(const Image& image, const CameraModel& camera,
                                 const PointCloud& points, const GroundSegParams& params,
                                 const std::string& image_name = "");

/// Confusion of a ground mask against per-pixel project labels (road/rough = ground; obstacle and
/// unknown/sky = non-ground), as Table 1 of paper 004.
struct GroundConfusion {
  std::size_t tp = 0, fn = 0, fp = 0, tn = 0;  ///< ground→ground, ground→non, non→ground, non→non
  void add(const GroundConfusion& o) { tp += o.tp; fn += o.fn; fp += o.fp; tn += o.tn; }
  std::size_t total() const { return tp + fn + fp + tn; }
  /// Share of the ground pixels found (97.68 % in Table 1).
  double groundFound() const { return tp + fn ? double(tp) / double(tp + fn) : 0.0; }
  /// Wrong pixels (both kinds) over all pixels (3.19 % in Table 1).
  double errorRate() const { return total() ? double(fn + fp) / double(total()) : 0.0; }
};
/// Throws InputError naming `truth_name` when the truth is not one channel of the segmented
/// image's size (an all-zero confusion would pass for an evaluated image).
GroundConfusion compareGround(const GroundSegmentation& seg, const Image& truth_labels,
                              const std::string& truth_name = "pixel truth");

}  // namespace terramrf::meshing
