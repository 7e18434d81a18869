#include "terramrf/meshing/mesh_builder.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "terramrf/errors.hpp"

namespace terramrf::meshing {

namespace {
// "000123" → 123 if the id is digits only (at most 18 of them), else -1.
long long numericId(const std::string& id) {
  if (id.empty() || id.size() > 18) return -1;
  long long v = 0;
  for (char ch : id) {
    if (ch < '0' || ch > '9') return -1;
    v = v * 10 + (ch - '0');
  }
  return v;
}
}  // namespace

std::vector<std::string> compactFrameIds(const std::vector<std::string>& ids) {
  std::vector<std::string> out;
  for (std::size_t i = 0; i < ids.size();) {
    const long long first = numericId(ids[i]);
    std::size_t j = i + 1;  // one past the run of ids[i]
    if (first >= 0)
      while (j < ids.size() && ids[j].size() == ids[i].size() &&
             numericId(ids[j]) == first + static_cast<long long>(j - i))
        ++j;
    if (j - i >= 3)
      out.push_back(ids[i] + "–" + ids[j - 1] + " (" + std::to_string(j - i) + " frames)");
    else
      for (std::size_t k = i; k < j; ++k) out.push_back(ids[k]);
    i = j;
  }
  return out;
}

namespace {
double msSince(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count();
}

// Ground/object votes of the vertices visible in one segmented image.
void voteVertices(TerrainMesh& mesh, const CameraView& view, const GroundSegmentation& seg,
                  double max_range_m) {
  const int span = mesh.tileSpan();
  const double cell = mesh.params().cell_m, L = span * cell;
  const Eigen::Vector3d C = view.centre();
  const int W = seg.width, H = seg.height;
  std::vector<std::pair<VertexKey, bool>> votes;
  for (auto& [key, tp] : mesh.tiles()) {
    Tile& t = *tp;
    const double x0 = t.ti * L, y0 = t.tj * L;
    const double dx = std::max({x0 - C.x(), 0.0, C.x() - (x0 + L)});
    const double dy = std::max({y0 - C.y(), 0.0, C.y() - (y0 + L)});
    if (dx * dx + dy * dy > max_range_m * max_range_m) continue;
    // Each global vertex votes once, from the tile that owns it (a far-border vertex belongs to
    // the neighbour when that exists, else to this tile).
    for (int i = 0; i < t.n; ++i)
      for (int j = 0; j < t.n; ++j) {
        const int k = i * t.n + j;
        if (!t.count[k] || !mesh.owns(t, i, j)) continue;
        const Eigen::Vector3d pw(x0 + i * cell, y0 + j * cell, t.z_sum[k] / t.count[k]);
        if ((pw.head<2>() - C.head<2>()).squaredNorm() > max_range_m * max_range_m) continue;
        double depth = 0;
        const auto uv = view.project(pw, &depth);
        if (!uv) continue;
        const int u = int(uv->x() + 0.5), v = int(uv->y() + 0.5);
        if (u >= W || v >= H || !view.visible(u, v, depth)) continue;
        votes.push_back({{int64_t(t.ti) * span + i, int64_t(t.tj) * span + j}, seg.isGround(u, v)});
      }
  }
  for (const auto& [key, ground] : votes) {
    const bool g = ground;  // C++17 lambdas cannot capture a structured binding (clang refuses)
    mesh.forEachCopy(key, [&](Tile& t, int k) {
      uint32_t& c = g ? t.ground_votes[k] : t.object_votes[k];
      if (c < UINT32_MAX) ++c;
    });
  }
}
}  // namespace

MeshBuilder::MeshBuilder(const MeshBuilderParams& p) : p_(p), mesh_(p.mesh) {}

FrameReport MeshBuilder::addFrame(const Frame& frame) {
  FrameReport rep;
  rep.id = frame.id;
  ++sum_.frames;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  if (frame.pose) {
    T = *frame.pose;
  } else {
    sum_.frames_without_pose.push_back(frame.id);
    rep.notes.push_back("no pose: the LiDAR frame is used as the world frame");
  }
  rep.skipped_far = mesh_.addCloud(frame.points, T, p_.max_range_m);
  rep.registered = frame.points.size() - rep.skipped_far;
  sum_.points_registered += rep.registered;
  sum_.points_skipped_far += rep.skipped_far;

  for (std::size_t ci = 0; ci < frame.cameras.size(); ++ci) {
    const CameraImage& ci_img = frame.cameras[ci];
    if (!ci_img.image || ci_img.image->empty()) continue;
    const Image& img = *ci_img.image;
    CameraModel cam = ci_img.model;
    if (!cam.width || !cam.height) {
      cam.width = img.width;
      cam.height = img.height;
    }
    const std::string cam_id = cam.name.empty() ? "camera" + std::to_string(ci) : cam.name;
    const std::string cam_name =
        cam_id + (ci_img.source_path.empty() ? "" : " (" + ci_img.source_path + ")");
    // Checked before anything is taken from the image: with another size every projection would
    // be clamped to the image edge (texture from wrong pixels), and the segmentation needs RGB.
    // These are not "cameras looking away": listed apart, with the reason.
    std::string rejected;
    if (img.width != cam.width || img.height != cam.height)
      rejected = "image is " + std::to_string(img.width) + "x" + std::to_string(img.height) +
                 " px but its camera model says " + std::to_string(cam.width) + "x" +
                 std::to_string(cam.height) + "; expected the model's size (image not used)";
    else if (p_.segment && img.channels != 3)
      rejected = "image has " + std::to_string(img.channels) +
                 " channel(s); expected RGB (3) for ground segmentation (image not used)";
    if (!rejected.empty()) {
      const InputError e(cam_name, rejected);
      sum_.images_rejected.push_back(frame.id + "/" + e.what());
      rep.notes.push_back(e.what());
      continue;
    }
    auto t0 = std::chrono::steady_clock::now();
    GroundSegmentation seg;
    bool have_seg = false;
    if (p_.segment) {
      try {
        seg = segmentGround(img, cam, frame.points, p_.ground, cam_name);
        have_seg = true;
      } catch (const InputError& e) {
        sum_.cameras_looking_away.push_back(frame.id + "/" + cam_name + ": " + e.what());
        rep.notes.push_back(e.what());
        continue;
      }
      rep.segmentation_ms += msSince(t0);
      sum_.segmentation_ms.push_back(msSince(t0));
    }
    ++rep.images_used;
    t0 = std::chrono::steady_clock::now();
    const CameraView view(cam, T, frame.points);
    if (have_seg) voteVertices(mesh_, view, seg, p_.max_range_m);
    mesh_.bakeTexture(view, img, p_.max_range_m);
    rep.texture_ms += msSince(t0);
    CameraSegmentation cs;
    cs.camera_index = ci;
    cs.camera = cam_id;
    if (have_seg && p_.recover) {
      t0 = std::chrono::steady_clock::now();
      SceneRecoveryStats rs = recoverHeights(mesh_, view, img, seg, frame.points, p_.recovery);
      sum_.raised_estimates += rs.raised;
      cs.object_mask = std::move(rs.object_mask);
      rep.recovery_ms += msSince(t0);
    }
    if (have_seg && ci_img.truth && !ci_img.truth->empty()) {
      // A truth image that does not fit is no evaluation: counted as one it would add an
      // all-zero confusion and still count the frame.
      try {
        rep.confusion.add(compareGround(seg, *ci_img.truth, cam_name + " pixel truth"));
        rep.has_truth = true;
      } catch (const InputError& e) {
        sum_.truth_rejected.push_back(frame.id + "/" + e.what());
        rep.notes.push_back(std::string(e.what()) + " (not evaluated)");
      }
    }
    if (have_seg) {
      cs.ground = std::move(seg);
      rep.segmentations.push_back(std::move(cs));
    }
  }
  if (rep.images_used == 0) {
    sum_.frames_without_image.push_back(frame.id);
    rep.notes.push_back("no usable camera image: points meshed without texture or segmentation");
  }
  if (rep.has_truth) {
    sum_.confusion.add(rep.confusion);
    ++sum_.truth_frames;
  }
  return rep;
}

MaskStats MeshBuilder::finish() {
  if (!p_.classify) {
    classifyGroundObject(mesh_);
    return {};
  }
  return classifyVertices(mesh_, p_.mask);
}

std::string MeshBuilder::report(const MaskStats* mask, const ExportStats* ex) const {
  std::ostringstream o;
  char buf[256];
  o << "# Textured terrain mesh (paper 004)\n\n";
  o << "- frames: " << sum_.frames << "\n";
  o << "- tiles: " << mesh_.tileCount() << " (" << mesh_.params().tile_vertices << "x"
    << mesh_.params().tile_vertices << " vertices, cell " << mesh_.params().cell_m << " m)\n";
  const std::size_t with_data = mesh_.verticesWithData(), textured = mesh_.texturedVertices();
  o << "- vertices with data: " << with_data << ", textured: " << textured
    << ", untextured: " << (with_data - textured) << "\n";
  if (ex && ex->tiles == 0)
    o << "- exported: nothing (no mesh files written): " << emptyMeshReason() << "\n";
  else if (ex)
    o << "- exported: " << ex->tiles << " tiles, " << ex->vertices << " vertices, " << ex->triangles
      << " triangles\n";
  if (mask)
    o << "- object vertices: " << mask->object_vertices << " (building " << mask->buildings
      << ", tree/other " << mask->trees << ")\n";
  o << "- height estimates above the LiDAR top: " << sum_.raised_estimates << "\n";
  if (!sum_.segmentation_ms.empty()) {
    double s = 0;
    for (double v : sum_.segmentation_ms) s += v;
    std::snprintf(buf, sizeof buf, "- ground segmentation (%s): %.2f ms per image (mean of %zu)\n",
                  toString(p_.ground.mrf.mode), s / sum_.segmentation_ms.size(),
                  sum_.segmentation_ms.size());
    o << buf;
  }
  auto list = [&](const char* what, const std::vector<std::string>& v) {
    if (v.empty()) return;
    o << "- " << what << ": " << v.size() << "\n";
    for (const auto& s : v) o << "  - " << s << "\n";
  };
  // A LiDAR-only log has every frame without an image: runs of consecutive ids, one line each.
  auto frameList = [&](const char* what, const std::vector<std::string>& v) {
    if (v.empty()) return;
    o << "- " << what << ": " << v.size() << "\n";
    for (const auto& s : compactFrameIds(v)) o << "  - " << s << "\n";
  };
  frameList("frames without a camera image (mesh untextured there)", sum_.frames_without_image);
  frameList("frames without a pose (LiDAR frame used as world)", sum_.frames_without_pose);
  list("cameras that see none of the points (skipped)", sum_.cameras_looking_away);
  list("camera images rejected", sum_.images_rejected);
  list("pixel truth images rejected (not evaluated)", sum_.truth_rejected);
  if (sum_.truth_frames) {
    const GroundConfusion& c = sum_.confusion;
    o << "\n## Image ground segmentation vs pixel truth (" << sum_.truth_frames << " image(s))\n\n";
    o << "| truth / inferred | ground | non-ground |\n|---|---:|---:|\n";
    o << "| ground | " << c.tp << " | " << c.fn << " |\n| non-ground | " << c.fp << " | " << c.tn
      << " |\n\n";
    std::snprintf(buf, sizeof buf,
                  "Ground pixels found: %.2f %% (paper Table 1: 97.68 %%); errors over all pixels: "
                  "%.2f %% (paper: 3.19 %%)\n",
                  100 * c.groundFound(), 100 * c.errorRate());
    o << buf;
  }
  return o.str();
}

std::string MeshBuilder::emptyMeshReason() const {
  std::ostringstream o;
  if (sum_.points_registered == 0) {
    o << "no LiDAR point within max_range_m = " << p_.max_range_m << " m of the sensor ("
      << sum_.points_skipped_far << " farther, over " << sum_.frames << " frame(s))";
  } else {
    o << "the " << mesh_.verticesWithData() << " vertices with data (from "
      << sum_.points_registered
      << " points) form no triangle: a cell needs three corners with data";
  }
  return o.str();
}

Image overlaySegmentation(const Image& image, const std::vector<uint8_t>& ground,
                          const std::vector<uint8_t>& objects) {
  Image out = image;
  if (out.channels != 3) return out;
  const std::size_t N = std::size_t(out.width) * out.height;
  for (std::size_t s = 0; s < N; ++s) {
    uint8_t* px = &out.data[s * 3];
    const bool g = ground.size() == N && ground[s];
    const bool ob = objects.size() == N && objects[s];
    if (!g && !ob) continue;
    const int tint[3] = {g ? 40 : 255, g ? 90 : 200, g ? 255 : 0};
    for (int c = 0; c < 3; ++c) px[c] = uint8_t((px[c] + tint[c]) / 2);
  }
  return out;
}

}  // namespace terramrf::meshing
