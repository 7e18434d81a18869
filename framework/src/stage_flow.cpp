// The order and read/write check of a pipeline's plugins (config_internal.hpp, StageFlow).
#include "config_internal.hpp"

namespace terramrf::detail {

StageFlow::StageFlow(Diags& d) : d_(d) {}

void StageFlow::addWrite(const std::string& w) {
  if (available_.insert(w).second) available_order_.push_back(w);
}

void StageFlow::buildGrid() {
  if (grid_built_) return;
  grid_built_ = true;
  addWrite(artefacts::kPoints);
}

std::string StageFlow::availableText() const {
  std::string have;
  for (const auto& a : available_order_) have += (have.empty() ? "" : ", ") + a;
  return have.empty() ? "nothing" : have;
}

void StageFlow::source(const Source& s, const YAML::Mark& m) {
  source_ = "source '" + s.name() + "' (" + s.type() + ")";
  for (const auto& w : s.writes()) {
    // Frame artefacts, and grid layers (with the label layer) that a source receives made
    // elsewhere (Frame::grid). The rest the runner makes per frame, after the source.
    if (w == artefacts::kPoints || w == artefacts::kEnergy || w == artefacts::kCellPixels) {
      d_.add(m,
             "declares that it writes '" + w +
                 "', which a source cannot: the runner bins each frame's points into the grid "
                 "('" +
                 artefacts::kPoints + "') after it is read, and the energy model ('" +
                 artefacts::kEnergy + "') and the cameras' pixels per cell ('" +
                 artefacts::kCellPixels +
                 "') are made by stages; a source provides the frame (its points, frame "
                 "artefacts such as '" +
                 artefacts::kPose + "', and grid layers received with it: Frame::grid)",
             s.name(), s.type());
      continue;
    }
    addWrite(w);
  }
}

void StageFlow::sourceLayers(const Source& s) {
  for (const auto& w : s.writes())
    if (!artefacts::isFrameArtefact(w) && w != artefacts::kPoints && w != artefacts::kEnergy &&
        w != artefacts::kCellPixels)
      addWrite(w);
}

void StageFlow::checkRead(const Plugin& p, const std::string& r, const YAML::Mark& m) {
  if (available_.count(r) || an_entry_failed_) return;
  if (source_failed_ && r != artefacts::kEnergy && r != artefacts::kCellPixels) return;
  if (artefacts::isFrameArtefact(r)) {
    // Without the source its frame artefacts are unknown: the pipeline's own check, with its
    // source, decides.
    if (source_.empty()) return;
    std::string msg = "reads '" + r + "', which neither " + source_ +
                      " nor an earlier stage writes (available here: " + availableText() + ")";
    if (r == artefacts::kPose)
      msg +=
          "; a pose comes from a source that has one for every frame (simulator, "
          "semantickitti with poses.txt, pointcloud_file PCDs with VIEWPOINTs) or from an "
          "egomotion stage before it";
    d_.add(m, msg, p.name(), p.type());
    return;
  }
  d_.add(
      m,
      "reads '" + r + "', which no earlier stage writes (available here: " + availableText() + ")",
      p.name(), p.type());
}

void StageFlow::stage(const Plugin& p, PluginKind kind, const YAML::Mark& m) {
  const bool ego = kind == PluginKind::kEgomotion;
  if (ego && !first_non_ego_.empty())
    d_.add(m,
           "egomotion stages must come before feature/energy/optimiser stages (the grid is built "
           "after the pose is known); this one follows " +
               first_non_ego_ + ", so it would run on a grid already built without it",
           p.name(), p.type());
  // The runner runs the leading egomotion stages on the frame alone, then builds the grid.
  const bool before_grid = ego && first_non_ego_.empty();
  if (!before_grid) {
    if (first_non_ego_.empty()) first_non_ego_ = "'" + p.name() + "' (" + p.type() + ")";
    buildGrid();
  }
  for (const auto& r : p.reads()) {
    if (before_grid && !artefacts::isFrameArtefact(r)) {
      // Whatever wrote it: nothing on the grid exists yet (the grid is empty when it runs).
      d_.add(m,
             "reads '" + r +
                 "', which an egomotion stage cannot: it runs before the grid is built, when no "
                 "grid layer and none of the grid's point lists ('" +
                 artefacts::kPoints +
                 "') exist; it has the frame (FrameContext::frame: its points, pose, IMU, GPS, "
                 "odometry)",
             p.name(), p.type());
      continue;
    }
    checkRead(p, r, m);
  }
  for (const auto& w : p.writes()) {
    if (before_grid && !artefacts::isFrameArtefact(w)) {
      // The runner builds the grid anew after the egomotion stages: it would be gone before any
      // stage read it.
      d_.add(m,
             "writes '" + w +
                 "', which would be lost: the grid is built anew from the frame's points after "
                 "the egomotion stages; an egomotion stage changes the frame (its points, its "
                 "pose: '" +
                 artefacts::kPose + "')",
             p.name(), p.type());
      continue;
    }
    addWrite(w);
  }
}

void StageFlow::output(const Plugin& p, const YAML::Mark& m) {
  buildGrid();
  for (const auto& r : p.reads()) checkRead(p, r, m);
}

}  // namespace terramrf::detail
