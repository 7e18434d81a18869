#pragma once
// The paper 004 pipeline over a sequence of frames (Fig. 1): register points in the tiled mesh,
// bake the texture, segment the ground in each image (§3.2) and vote the vertices' classes,
// recover object heights (§3.3); at the end classify buildings and trees (§3.4) and export.
// Frames without an image still add their points (that part of the mesh stays untextured; it is
// counted and reported); a camera that sees none of the points is reported and skipped, and so is
// an image that cannot be used (size other than its camera model's, not RGB for segmentation).
#include <Eigen/Geometry>
#include <map>
#include <string>
#include <vector>

#include "terramrf/frame.hpp"
#include "terramrf/meshing/building_mask.hpp"
#include "terramrf/meshing/ground_segmentation.hpp"
#include "terramrf/meshing/mesh_export.hpp"
#include "terramrf/meshing/scene_recovery.hpp"
#include "terramrf/meshing/terrain_mesh.hpp"

namespace terramrf::meshing {

struct MeshBuilderParams {
  TerrainMeshParams mesh;
  double max_range_m = 40.0;  ///< points farther from the sensor are not registered [m]
  bool segment = true;        ///< §3.2 (without it every vertex stays unknown)
  bool recover = true;        ///< §3.3
  bool classify = true;       ///< §3.4
  GroundSegParams ground;
  SceneRecoveryParams recovery;
  MaskParams mask;
};

/// One camera's segmentation in one frame (for overlays and tests).
struct CameraSegmentation {
  std::size_t camera_index = 0;      ///< into Frame::cameras
  std::string camera;                ///< CameraModel::name, "camera<index>" without one
  GroundSegmentation ground;         ///< §3.2
  std::vector<uint8_t> object_mask;  ///< §3.3 object pixels; empty without recovery
};

struct FrameReport {
  std::string id;
  std::size_t registered = 0, skipped_far = 0;
  int images_used = 0;
  std::vector<std::string> notes;   ///< problems reported for this frame
  bool has_truth = false;
  GroundConfusion confusion;        ///< when the image has pixel truth
  double segmentation_ms = 0, recovery_ms = 0, texture_ms = 0;
  /// Every camera segmented in this frame, in Frame::cameras order; a camera whose image was
  /// rejected or saw no point has none.
  std::vector<CameraSegmentation> segmentations;
};

struct BuilderSummary {
  std::size_t frames = 0;
  std::vector<std::string> frames_without_image;
  std::vector<std::string> frames_without_pose;
  std::vector<std::string> cameras_looking_away;  ///< "frame/camera: message"
  std::vector<std::string> images_rejected;       ///< "frame/camera: why" (size, channels)
  std::vector<std::string> truth_rejected;        ///< "frame/camera truth: why" (not evaluated)
  std::size_t points_registered = 0, points_skipped_far = 0;  ///< over all frames
  GroundConfusion confusion;
  std::size_t truth_frames = 0;
  std::vector<double> segmentation_ms;
  std::size_t raised_estimates = 0;
};

class MeshBuilder {
 public:
  explicit MeshBuilder(const MeshBuilderParams& p = {});

  /// Adds one frame (pose: Frame::pose, identity when absent — reported).
  FrameReport addFrame(const Frame& frame);
  /// Classifies the vertices (ground/object from the votes, building/tree by masking).
  MaskStats finish();

  const TerrainMesh& mesh() const { return mesh_; }
  TerrainMesh& mesh() { return mesh_; }
  const BuilderSummary& summary() const { return sum_; }
  const MeshBuilderParams& params() const { return p_; }

  /// Human-readable report (Markdown): counts, problems, Table-1-style confusion.
  std::string report(const MaskStats* mask = nullptr, const ExportStats* exported = nullptr) const;
  /// Why the mesh has no triangle to export (for report.md and the log): no point in range, or
  /// too few vertices with data.
  std::string emptyMeshReason() const;

 private:
  MeshBuilderParams p_;
  TerrainMesh mesh_;
  BuilderSummary sum_;
};

/// Frame ids for a report: runs of three or more consecutive numeric ids of one width become one
/// entry "000018–000199 (182 frames)"; other ids are kept as they are, in order. Lossless.
std::vector<std::string> compactFrameIds(const std::vector<std::string>& ids);

/// Overlay of the classes on an image for inspection: ground blue, tree green, building red,
/// other objects yellow; `ground`/`objects` masks (may be empty) are blended in.
Image overlaySegmentation(const Image& image, const std::vector<uint8_t>& ground,
                          const std::vector<uint8_t>& objects);

}  // namespace terramrf::meshing
