// Output "textured_mesh": the textured terrain mesh of paper 004 built over the whole run
// (meshing/mesh_builder.hpp) and exported at the end as OBJ+MTL+PNG, PLY and glTF (.glb), with a
// report (counts, frames without images, cameras that saw no points, ground segmentation vs pixel
// truth when the source has it).
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <string>

#include "terramrf/adapters/opencv_image.hpp"
#include "terramrf/atomic_file.hpp"
#include "terramrf/meshing/mesh_builder.hpp"
#include "terramrf/output_folder.hpp"
#include "terramrf/plugin.hpp"
#include "terramrf/stop_request.hpp"

namespace terramrf {
namespace {

namespace fs = std::filesystem;
using namespace meshing;

class TexturedMeshOutput : public Output {
 public:
  void declare(ParamDecl& d) override {
    d.add("subdir", subdir_, "folder of the export, relative to the run's output folder");
    d.add("formats", formats_, "any of obj (with .mtl and PNG textures), ply, gltf (.glb)");
    d.add("tile_vertices", p_.mesh.tile_vertices, "vertices per tile side (paper: 151)")
        .unit("1")
        .range(2, 2001);
    d.add("cell_m", p_.mesh.cell_m, "vertex spacing (paper: 0.125)").unit("m").range(0.01, 10);
    d.add("texels_per_cell", p_.mesh.texels_per_cell, "texture resolution per cell side")
        .unit("1")
        .range(1, 8);
    d.add("max_range_m", p_.max_range_m, "points farther from the sensor are not registered")
        .unit("m")
        .range(1, 500);
    d.add("segment", p_.segment, "segment the ground in the images (§3.2)");
    d.add("recover", p_.recover, "recover object heights beyond the LiDAR's reach (§3.3)");
    d.add("classify", p_.classify, "split objects into buildings and trees by masking (§3.4)");
    d.add("sensor_height_m", p_.ground.sensor_height_m, "h1: LiDAR above the ground")
        .unit("m")
        .range(0, 10);
    d.add("band_m", p_.ground.band_m, "Δ: half width of the rough ground band")
        .unit("m")
        .range(0.01, 2);
    d.add("local_seeds", p_.ground.local_seeds, "also seed flat ground outside the band (hills)");
    d.add("fit_ground_plane", p_.ground.fit_ground_plane,
          "fit the ground plane to the LiDAR (start: z = -h1) and put the band around it (pitched "
          "vehicle, unknown mount height)");
    d.add("plane_fit_range_m", p_.ground.plane_fit_range_m,
          "fit_ground_plane: cells within this range")
        .unit("m")
        .range(2, 200);
    d.add("seed_max_step_m", p_.ground.seed_max_step_m,
          "seeds lie in a 0.5 m cell whose points span less than this in height")
        .unit("m")
        .range(0.01, 2);
    d.add("lidar_observation_px", p_.ground.lidar_observation_px,
          "pixels this close to a LiDAR return take its class as observation (eq. 10)")
        .unit("px")
        .range(0, 50);
    d.add("column_fill_px", p_.ground.column_fill_px,
          "pixels between two ground returns this close in one image column are observed ground (0 "
          "= off)")
        .unit("px")
        .range(0, 500);
    d.add("column_fill_halfwidth_px", p_.ground.column_fill_halfwidth_px,
          "for that fill a return also stands for this many columns either side (LiDAR sparser "
          "than the image)")
        .unit("px")
        .range(0, 50);
    d.add("colour_smooth_px", p_.ground.colour_smooth_px,
          "colour observations are box means over (2k+1)^2 pixels (textured ground in fine images; "
          "0 = raw)")
        .unit("px")
        .range(0, 50);
    d.add("colour_band_rows", p_.ground.colour_band_rows,
          "colour histograms per band of this many image rows (0 = one for the image)")
        .unit("px")
        .range(0, 10000);
    d.add("mode", mode_, "ground MRF solver: flood_fill (paper's fast one) or gibbs (whole image)")
        .choices({"flood_fill", "gibbs"});
    d.add("alpha", p_.ground.mrf.alpha, "eq. 9-10 weight").unit("1").range(0, 100);
    d.add("beta", p_.ground.mrf.beta, "eq. 11 weight").unit("1").range(0, 100);
    d.add("gamma", p_.ground.mrf.gamma, "eq. 12 weight").unit("1").range(0, 100);
    d.add("colour_scale", p_.ground.mrf.colour_scale, "RGB distance scale of eq. 12")
        .unit("grey levels")
        .range(0.1, 500);
    d.add("max_sweeps", p_.ground.mrf.max_sweeps, "gibbs mode: sweeps at most")
        .unit("1")
        .range(1, 1000);
    d.add("mask_size", p_.mask.size, "s of eq. 13: masks are (2s+1)^2 vertices")
        .unit("1")
        .range(1, 20);
    d.add("mask_orientations", p_.mask.orientations, "line directions of the masks (paper: 4)")
        .unit("1")
        .range(1, 32);
    d.add("mask_threshold", p_.mask.threshold,
          "U above this = building (normalised: 0..1; else metres)")
        .unit("1")
        .range(-1e3, 1e3);
    d.add("mask_normalise", p_.mask.normalise,
          "divide U by the elevation of a complete wall on the line (1 = filled straight line)");
    d.add("mask_line_tolerance", p_.mask.line_tolerance,
          "t: grey-dilate the elevation by (2t+1)^2 vertices before masking, so sampled walls fill "
          "a straight line")
        .unit("vertices")
        .range(0, 5);
    d.add("recovery_background_odds", p_.recovery.background_odds,
          "§3.3: a colour is background only where it is this many times more frequent far from "
          "LiDAR returns than at object returns")
        .unit("1")
        .range(0.01, 1e4);
    d.add("recovery_stop_at_occluders", p_.recovery.stop_at_occluders,
          "§3.3: a column walk under a clearly nearer LiDAR surface gives only a lower bound");
    d.add("write_overlays", write_overlays_,
          "write overlays/<frame>_<camera>.png in the mesh folder: each camera image with its own "
          "ground segmentation and object mask drawn over it (none for a camera not segmented)");
    d.add("decimate", decimate_,
          "collapse flat regions of the exported mesh (CGAL edge collapse; "
          "tile borders, holes and class boundaries stay; texture coordinates stay exact)");
    d.add("flat_tolerance_m", flat_tolerance_m_,
          "decimate: largest vertical distance of an original vertex from the decimated surface")
        .unit("m")
        .range(0.001, 1.0);
  }

  void configure(const PluginContext& ctx) override {
    checkOutputSubdir(subdir_, "mesh");
    if (formats_.empty()) throw ParamError("formats", "is empty; expected any of obj, ply, gltf");
    ex_ = ExportOptions{false, false, false};
    ex_.decimate = decimate_;
    ex_.flat_tolerance_m = flat_tolerance_m_;
    for (const auto& f : formats_) {
      if (f == "obj")
        ex_.obj = true;
      else if (f == "ply")
        ex_.ply = true;
      else if (f == "gltf" || f == "glb")
        ex_.gltf = true;
      else
        throw ParamError("formats", "unknown format '" + f + "'; expected obj, ply or gltf");
    }
    // Tiles are allocated whole, each as soon as a point falls in it: refuse at the config what
    // would exhaust the memory mid-drive (at the bounds, 2001 and 8, one tile took 1.7 GiB).
    // With one texel per cell no tile within the bounds is too large, so the texels are named.
    if (const std::string why = tileBudgetProblem(p_.mesh); !why.empty())
      throw ParamError(p_.mesh.texels_per_cell > 1 ? "texels_per_cell" : "tile_vertices", why);
    p_.ground.mrf.mode = parseMrfMode(mode_);
    output_dir_ = ctx.output_dir;
  }

  void begin(const RunInfo& info) override {
    if (!info.output_dir.empty()) output_dir_ = info.output_dir;
    // Fail before any frame is processed when the export could never be written.
    checkWritableFolder((fs::path(output_dir_) / subdir_).parent_path().string());
    builder_ = std::make_unique<MeshBuilder>(p_);
    note_counts_.clear();
    // This run's overlays gather beside the export, never among an earlier run's, and move into
    // the new export with it.
    std::error_code ec;
    fs::remove_all(stagedOverlays(), ec);
  }

  void write(const FrameContext& ctx) override {
    if (!ctx.frame) throw std::invalid_argument("textured_mesh: frame context without a frame");
    if (!builder_) builder_ = std::make_unique<MeshBuilder>(p_);
    const FrameReport r = builder_->addFrame(*ctx.frame);
    for (const auto& n : r.notes) {
      // A LiDAR-only log has the same note on every frame: the first few are printed, the rest
      // counted and summed up at the end (report.md lists the frames).
      const std::size_t seen = ++note_counts_[n];
      if (seen > kNotesPrinted) continue;
      std::cerr << "textured_mesh: frame " << r.id << ": " << n
                << (seen == kNotesPrinted ? " (further frames with this note are counted, not "
                                            "printed; report.md lists them)"
                                          : "")
                << "\n";
    }
    if (write_overlays_) {
      // Each camera with its own segmentation and object mask; a camera without one (image
      // rejected, no point in view) gets no overlay. Names go through safeFileName: frame ids
      // and camera names come from the data.
      for (const CameraSegmentation& cs : r.segmentations) {
        const CameraImage& cam = ctx.frame->cameras.at(cs.camera_index);
        const Image o = overlaySegmentation(*cam.image, cs.ground.ground, cs.object_mask);
        writeImageAtomic(
            (stagedOverlays() / (safeFileName(r.id) + "_" + safeFileName(cs.camera) + ".png"))
                .string(),
            o);
      }
    }
  }

  void end(const RunSummary& summary) override {
    for (const auto& [note, n] : note_counts_)
      if (n > kNotesPrinted)
        std::cerr << "textured_mesh: " << n << " frames in all: " << note << "\n";
    note_counts_.clear();
    if (!builder_) return;
    const MaskStats ms = builder_->finish();
    const std::string dir = (fs::path(output_dir_) / subdir_).string();
    ExportStats es;
    const fs::path staged = stagedOverlays();
    ExportOptions ex = ex_;
    // report.md goes into the export's temporary folder, so it is swapped in with the mesh it
    // describes (a failing export keeps the previous mesh and its own report).
    ex.add_files = [&](const std::string& folder, const ExportStats& st) {
      // An interrupted run's mesh covers its first frames only: said first.
      const std::string stopped = interruptionText(summary);
      writeFileAtomic(
          (fs::path(folder) / "report.md").string(),
          (stopped.empty() ? "" : "**Run " + stopped + "**: this mesh covers those only.\n\n") +
              builder_->report(&ms, &st));
    };
    try {
      es = exportMesh(builder_->mesh(), dir, ex);
    } catch (const std::exception& e) {
      if (!fs::exists(staged)) throw;
      throw std::runtime_error(std::string(e.what()) + "; this run's overlays are in " +
                               staged.string());
    }
    if (fs::exists(staged)) {
      std::error_code ec;
      fs::rename(staged, fs::path(dir) / "overlays", ec);
      if (ec)
        throw std::runtime_error("mesh exported to " + dir +
                                 ", but its overlays could not be moved there from " +
                                 staged.string() + ": " + ec.message());
    }
    if (es.tiles == 0)
      std::cerr << "textured_mesh: no mesh written to " << dir << ": "
                << builder_->emptyMeshReason() << " (see report.md)\n";
    else
      std::cerr << "textured_mesh: " << es.tiles << " tile(s), " << es.vertices << " vertices, "
                << es.triangles << " triangles -> " << dir << "\n";
    if (ex_.decimate)
      std::fprintf(stderr,
                   "textured_mesh: decimated %zu -> %zu triangles (%.1f %%), deviation <= %.3f m\n",
                   es.triangles_before_decimation, es.triangles,
                   100.0 * double(es.triangles) /
                       double(std::max<std::size_t>(1, es.triangles_before_decimation)),
                   es.max_deviation_m);
    const auto& s = builder_->summary();
    if (!s.frames_without_image.empty())
      std::cerr
          << "textured_mesh: " << s.frames_without_image.size()
          << " frame(s) without a usable camera image: mesh untextured there (see report.md)\n";
    if (!s.images_rejected.empty())
      std::cerr << "textured_mesh: " << s.images_rejected.size()
                << " camera image(s) rejected, not used (see report.md)\n";
    if (!s.truth_rejected.empty())
      std::cerr << "textured_mesh: " << s.truth_rejected.size()
                << " pixel truth image(s) rejected, not evaluated (see report.md)\n";
    if (s.truth_frames)
      std::fprintf(stderr,
                   "textured_mesh: image ground segmentation: %.2f %% of ground pixels found, %.2f "
                   "%% errors\n",
                   100 * s.confusion.groundFound(), 100 * s.confusion.errorRate());
  }

 private:
  /// Where this run's overlays are written until the export is in place.
  fs::path stagedOverlays() const { return fs::path(output_dir_) / (subdir_ + ".overlays-new"); }

  std::string subdir_ = "mesh";
  std::vector<std::string> formats_{"obj", "ply", "gltf"};
  std::string mode_ = "flood_fill";
  bool write_overlays_ = false;
  bool decimate_ = false;
  double flat_tolerance_m_ = 0.05;
  MeshBuilderParams p_;
  ExportOptions ex_;
  std::string output_dir_ = ".";
  std::unique_ptr<MeshBuilder> builder_;
  static constexpr std::size_t kNotesPrinted = 3;   ///< times one note is printed per run
  std::map<std::string, std::size_t> note_counts_;  ///< frames with each note
};

}  // namespace
}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::TexturedMeshOutput, terramrf::PluginKind::kOutput, "textured_mesh",
                "textured terrain mesh of paper 004 (tiles, image ground segmentation, scene "
                "recovery, building/tree masking) exported as OBJ/PLY/glTF")
