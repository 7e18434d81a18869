#include "terramrf/pipeline.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <numeric>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <system_error>
#include <thread>

#include "frame_reader.hpp"
#include "terramrf/atomic_file.hpp"
#include "terramrf/params.hpp"
#include "terramrf/run_state.hpp"
#include "terramrf/stop_request.hpp"
#include "terramrf/text_format.hpp"

namespace terramrf {

double StageTiming::mean() const {
  return ms.empty() ? NAN : std::accumulate(ms.begin(), ms.end(), 0.0) / ms.size();
}
double StageTiming::stddev() const {
  if (ms.size() < 2) return NAN;  // undefined from one scan, not 0
  const double m = mean();
  double s = 0;
  for (double v : ms) s += (v - m) * (v - m);
  return std::sqrt(s / (ms.size() - 1));
}
double StageTiming::min() const {
  return ms.empty() ? NAN : *std::min_element(ms.begin(), ms.end());
}
double StageTiming::max() const {
  return ms.empty() ? NAN : *std::max_element(ms.begin(), ms.end());
}
double StageTiming::median() const {
  if (ms.empty()) return NAN;
  std::vector<double> v = ms;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  double m = v[v.size() / 2];
  if (v.size() % 2 == 0) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2 - 1, v.end());
    m = 0.5 * (m + v[v.size() / 2 - 1]);
  }
  return m;
}

PoseError poseError(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth) {
  PoseError e;
  e.translation_m = (estimate.translation() - truth.translation()).norm();
  // The angle of the rotation between the two, whatever its axis: 0 to 180°.
  const Eigen::AngleAxisd d(truth.linear().transpose() * estimate.linear());
  e.rotation_deg = d.angle() * 180.0 / M_PI;
  return e;
}

void PoseErrorSummary::add(const PoseError& e) {
  ++frames;
  translation_sum_m += e.translation_m;
  translation_max_m = std::max(translation_max_m, e.translation_m);
  rotation_sum_deg += e.rotation_deg;
  rotation_max_deg = std::max(rotation_max_deg, e.rotation_deg);
}
double PoseErrorSummary::translationMean_m() const {
  return frames ? translation_sum_m / double(frames) : NAN;
}
double PoseErrorSummary::rotationMean_deg() const {
  return frames ? rotation_sum_deg / double(frames) : NAN;
}

int RunResult::exitCode() const {
  if (summary.stop_signal != 0) return 128 + summary.stop_signal;
  if (!output_errors.empty()) return 4;
  // Every frame failed (a stream's total is unknown: frames_total 0).
  if (summary.frames_ok == 0 && !summary.failed.empty()) return 4;
  if (!summary.failed.empty()) return 3;
  return 0;
}

namespace {

// The run's own reports (writeRunReports), removed at the start of a run (runPipeline).
constexpr const char* kTimingFile = "timing.md";
constexpr const char* kMetricsFile = "metrics.csv";
constexpr const char* kMetricsHeader = "frame,metric,value\n";
void appendMetricsRows(std::ostream& o, const std::string& frame,
                       const std::map<std::string, double>& m) {
  for (const auto& [key, value] : m)
    o << csvField(frame) << ',' << csvField(key) << ',' << value << '\n';
}

// RunOptions::metrics_csv: rows appended and flushed per frame to `<path>.partial`, renamed when
// the run ends. A write that fails (a full disk) falls back to memory: the rows from there on are
// written at the end by writeRunReports, those before stay in the partial file, and the run says
// so as an error of its reports (the file is incomplete).
class MetricsStream {
 public:
  MetricsStream(const std::string& path, std::ostream& log) : path_(path), log_(log) {
    if (path.empty()) return;
    out_.open(partial(), std::ios::trunc);
    out_.precision(9);
    out_ << kMetricsHeader << std::flush;
    if (!out_) {
      // Nothing in it yet: no partial file is left to explain.
      out_.close();
      std::error_code ec;
      std::filesystem::remove(partial(), ec);
      log_ << "warning: " << partial()
           << " cannot be written; the metrics are kept in memory and written at the end\n";
    }
  }
  bool active() const { return out_.is_open(); }
  /// False if the rows could not be written (they then belong in memory).
  bool append(const std::string& frame, const std::map<std::string, double>& m) {
    if (!active()) return false;
    appendMetricsRows(out_, frame, m);
    out_.flush();
    if (out_) return true;
    failed_before_ = frame;
    out_.close();
    log_ << "warning: " << partial() << " could not be written on at frame " << frame
         << "; the metrics from there on are kept in memory, those before stay in that file\n";
    return false;
  }
  /// The final file's path, or "" if the rows are not all in it (then `error` says why).
  std::string finish(std::string& error) {
    if (!failed_before_.empty()) {
      error = "metrics.csv is incomplete: the rows before frame " + failed_before_ + " are in " +
              partial() + ", which could not be written on";
      return "";
    }
    if (!active()) return "";
    out_.close();
    std::error_code ec;
    if (!out_.fail()) std::filesystem::rename(partial(), path_, ec);
    if (out_.fail() || ec) {
      error = "metrics.csv is incomplete: " + partial() + " could not be " +
              (out_.fail() ? "closed" : "renamed to " + path_ + " (" + ec.message() + ")");
      return "";
    }
    return path_;
  }

 private:
  std::string partial() const { return path_ + ".partial"; }
  std::string path_;
  std::ostream& log_;
  std::ofstream out_;
  std::string failed_before_;  ///< the frame whose rows could not be written
};

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

class Progress {
 public:
  /// `stream`: the total is unknown (0); a count instead of a bar.
  Progress(std::size_t total, bool stream, bool enabled)
      : total_(total), stream_(stream), enabled_(enabled), tty_(::isatty(2) != 0) {}
  void update(std::size_t done, const std::string& id, double last_ms, std::size_t failed) {
    if (enabled_ && stream_) return updateStream(done, id, last_ms, failed);
    if (!enabled_ || total_ == 0) return;
    const std::size_t step = std::max<std::size_t>(1, total_ / 20);
    if (!tty_ && done != total_ && done % step != 0) return;
    const int width = 30;
    const int filled = static_cast<int>(width * done / total_);
    std::fprintf(stderr, "%s[%s%s] %zu/%zu %s %.1f ms/scan%s%s", tty_ ? "\r" : "",
                 std::string(filled, '#').c_str(), std::string(width - filled, '.').c_str(), done,
                 total_, id.c_str(), last_ms,
                 failed ? (" (" + std::to_string(failed) + " failed)").c_str() : "",
                 tty_ ? "\033[K" : "\n");
    if (tty_ && done == total_) std::fprintf(stderr, "\n");
    std::fflush(stderr);
  }

 private:
  /// A stream may run for hours: into a log (no terminal) a line every 10 s, not every frame.
  void updateStream(std::size_t done, const std::string& id, double last_ms, std::size_t failed) {
    const auto now = Clock::now();
    if (!tty_ && done > 1 && now - last_line_ < std::chrono::seconds(10)) return;
    last_line_ = now;
    std::fprintf(stderr, "%s%zu frame(s) %s %.1f ms/scan%s%s", tty_ ? "\r" : "", done, id.c_str(),
                 last_ms, failed ? (" (" + std::to_string(failed) + " failed)").c_str() : "",
                 tty_ ? "\033[K" : "\n");
    std::fflush(stderr);
  }

  std::size_t total_;
  bool stream_, enabled_, tty_;
  Clock::time_point last_line_{};
};

/// Adds the frame's dropped points to the run's counts. Non-finite points mean a damaged or
/// badly converted file, so each such frame is named; no-returns are normal and only counted.
void noteDroppedPoints(const Frame& f, RunResult& res, std::ostream& log, bool progress_bar) {
  res.points_dropped_nonfinite += f.dropped_nonfinite_points;
  res.points_dropped_no_return += f.dropped_no_return_points;
  if (f.dropped_nonfinite_points == 0 && !f.points.empty()) return;
  if (progress_bar && ::isatty(2)) std::fprintf(stderr, "\n");  // off the progress bar's line
  if (f.dropped_nonfinite_points > 0)
    log << "warning: frame " << f.id << ": " << f.dropped_nonfinite_points
        << " point(s) with NaN/inf coordinates or intensity dropped (" << f.source_path << ")\n";
  if (f.points.empty()) {
    res.empty_frames.push_back(f.id);
    log << "warning: frame " << f.id << " has no usable point ("
        << (f.dropped_nonfinite_points + f.dropped_no_return_points) << " dropped; "
        << f.source_path << "): every cell stays unknown\n";
  }
}

/// Frames whose ids name the same files (after safeFileName) would write over each other's
/// outputs, and a failed one would remove the other's as an earlier run's: refused before any
/// frame runs. A frame whose id cannot be had fails in the run itself, named there.
void requireDistinctFrameIds(const Source& src, std::size_t first, std::size_t n) {
  std::map<std::string, std::pair<std::size_t, std::string>> seen;  // file name → frame, id
  std::size_t clashes = 0;
  std::ostringstream first_clashes;
  for (std::size_t i = first; i < first + n; ++i) {
    std::string id;
    try {
      id = src.frameId(i);
    } catch (...) {
      continue;
    }
    const auto [it, fresh] = seen.emplace(safeFileName(id), std::pair{i, id});
    if (fresh || ++clashes > 5) continue;
    first_clashes << "\n  frames " << it->second.first << " ('" << it->second.second << "') and "
                  << i << " ('" << id << "') both write '" << it->first << "'";
  }
  if (clashes == 0) return;
  throw std::runtime_error(
      "source '" + src.type() + "': " + std::to_string(clashes) +
      " frame(s) share a file name with an earlier frame, so their outputs would write over each "
      "other's:" +
      first_clashes.str() + (clashes > 5 ? "\n  …" : "") +
      "\ngive every frame a distinct name (file names differ in more than their extension and "
      "in more than '/', ':' and spaces)");
}

// The layers a source received made (Frame::grid) become the frame's grid: those it declares,
// and the labels only if it declares '@labels' (nothing undeclared slips in). A frame without
// them fails, naming the source, the frame's file and what is missing: stages were let through
// on the source's declaration (the loaders' read/write check).
void adoptSourceGrid(const Source& source, const std::vector<std::string>& layers, const Frame& f,
                     TerrainGrid& grid) {
  const std::string who = "source '" + source.name() + "' (" + source.type() + ")";
  if (!f.grid)
    throw InputError(f.source_path, "has no grid, though " + who +
                                        " declares that it writes grid layers (" +
                                        joinNames(layers) + ") for every frame");
  std::vector<std::string> names;
  bool labels = false;
  for (const auto& l : layers) {
    if (l == artefacts::kLabels) {
      labels = true;
      continue;
    }
    if (!f.grid->has(l))
      throw InputError(f.source_path, "has no grid layer '" + l + "', though " + who +
                                          " declares that it writes it (layers received: " +
                                          joinNames(f.grid->layerNames()) + ")");
    names.push_back(l);
  }
  try {
    grid.adoptLayers(*f.grid, names, labels);
  } catch (const std::invalid_argument& e) {
    throw InputError(f.source_path, who + ": " + e.what());
  }
}

/// Warns about a frame whose points nearly all miss the grid, which is centred on the sensor: a
/// cloud stored in a map frame (a UTM PLY, a PCD without its VIEWPOINT) lies kilometres away, and
/// it gave an all-unknown grid and exit 0 without a word. Under 1 % of the points inside is named,
/// with where the cloud and the grid lie, so that the frame the points are in can be seen.
void noteCloudOutsideGrid(const Frame& f, const TerrainGrid& g, RunResult& res, std::ostream& log,
                          bool progress_bar) {
  const std::size_t n = f.points.size(), inside = g.pointsInside();
  if (n == 0 || inside * 100 >= n) return;  // no points: noteDroppedPoints said so
  res.frames_outside_grid.push_back(f.id);
  const PointCloud& c = f.points;
  const auto [x_lo, x_hi] = std::minmax_element(c.x.begin(), c.x.end());
  const auto [y_lo, y_hi] = std::minmax_element(c.y.begin(), c.y.end());
  const auto [z_lo, z_hi] = std::minmax_element(c.z.begin(), c.z.end());
  const GridGeometry& geo = g.geometry();
  const Eigen::Vector2d lo = geo.origin();
  const Eigen::Vector2d hi = lo + Eigen::Vector2d::Constant(geo.cols() * geo.cell_m);
  auto span = [](double a, double b) {  // [m]; a tenth is enough to see where a cloud lies
    char buf[96];
    std::snprintf(buf, sizeof buf, "[%.1f, %.1f]", a, b);
    return std::string(buf);
  };
  if (progress_bar && ::isatty(2)) std::fprintf(stderr, "\n");  // off the progress bar's line
  log << "warning: frame " << f.id << ": " << inside << " of " << n << " point(s) inside the grid, "
      << (n - inside) << " outside (" << f.source_path << "): the cloud spans x "
      << span(*x_lo, *x_hi) << ", y " << span(*y_lo, *y_hi) << ", z " << span(*z_lo, *z_hi)
      << " m, the grid x [" << numberText(lo.x()) << ", " << numberText(hi.x()) << "], y ["
      << numberText(lo.y()) << ", " << numberText(hi.y()) << "] m around the sensor, so "
      << (inside ? "nearly " : "")
      << "every cell stays unknown. Is the cloud in a map frame (e.g. UTM)? The grid needs it in "
         "the sensor frame: give a PCD the sensor's pose as its VIEWPOINT, use recentre: auto of "
         "semantickitti or pointcloud_file (a scan shifted by up to kilometres), or store the "
         "points relative to the sensor\n";
}

/// "stage '<name>' (<type>): ", as the config's errors name a stage.
std::string stageText(const Stage& s) { return "stage '" + s.name() + "' (" + s.type() + "): "; }

/// What the exception being handled says; called inside a catch. Plugins may throw anything (a
/// type of their own, an int): the run goes on all the same.
std::string currentExceptionText() {
  try {
    throw;
  } catch (const std::exception& e) {
    return e.what();
  } catch (...) {
    return "unknown exception (not a std::exception)";
  }
}
}  // namespace

RunResult runPipeline(Pipeline& p, const RunOptions& opt) {
  std::ostream& log = opt.log ? *opt.log : std::cerr;
  RunResult res;
  std::filesystem::create_directories(p.output_dir);
  // A run killed mid-write (before session 38 any SIGINT/SIGTERM, now a second one or SIGKILL)
  // leaves its temporaries; no later run would ever replace them.
  for (const auto& line : removeStaleTemps(p.output_dir))
    log << (line.rfind("cannot", 0) == 0 ? "warning: " : "note: ") << line << "\n";
  auto inOutputDir = [&](const std::string& f) {
    const std::filesystem::path path(f);
    return path.is_absolute() ? path : std::filesystem::path(p.output_dir) / path;
  };
  // An earlier run's summaries would pass for this run's should it stop before the end, where
  // they are written again, or fail in an output's begin(): they go before this run's resolved
  // config is written. Asked again after begin(), for an output that names them only then. Its
  // per-frame files are removed only for frames that fail (below).
  auto removeSummaries = [&] {
    std::vector<std::string> summaries = {kTimingFile, kMetricsFile,
                                          std::string(kMetricsFile) + ".partial"};
    if (!opt.metrics_csv.empty()) summaries.push_back(opt.metrics_csv + ".partial");
    for (auto& o : p.outputs)
      for (const auto& f : o->summaryFiles()) summaries.push_back(f);
    for (const auto& f : summaries) {
      std::error_code ec;
      std::filesystem::remove(inOutputDir(f), ec);
    }
  };
  removeSummaries();
  std::string frames_run;  // the frames are chosen on the command line, not in the config
  if (opt.first > 0 || opt.limit > 0)
    frames_run = "# This run: --first " + std::to_string(opt.first) +
                 (opt.limit ? " --limit " + std::to_string(opt.limit) : std::string()) +
                 " (give them again to run the same frames)\n";
  writeFileAtomic(p.output_dir + "/resolved_config.yaml", frames_run + p.resolved_yaml);

  // A stream's length is unknown: n is 0, and the run takes frames until it ends (or --limit).
  const bool stream = p.source->streaming();
  const std::size_t n_all = stream ? 0 : p.source->size();
  const std::size_t first = stream ? opt.first : std::min(opt.first, n_all);
  const std::size_t n =
      stream ? 0 : (opt.limit ? std::min(opt.limit, n_all - first) : n_all - first);
  res.frames_total = n;
  res.summary.frames_total = n;

  RunInfo info;
  info.config_path = p.config_path;
  info.output_dir = p.output_dir;
  info.frames = n;
  info.labels = p.labels.get();
  info.grid = p.grid;
  info.cameras = p.source->cameraNames();
  // Each run its own, even of one Pipeline run twice: a map left from another run would be
  // taken for this one's.
  RunState run_state;
  info.run = &run_state;
  if (!stream) requireDistinctFrameIds(*p.source, first, n);  // a stream's: as they come
  // Stages first: one that cannot begin (a map store that does not open) then fails the run
  // before any output has begun, so no output is left begun and never ended. Nothing ends then:
  // end() of a run that never ran would write summaries and maps of no frame beside the failed
  // run's config; a stage releases what begin() took in its destructor too (Stage::begin).
  for (auto& s : p.stages) {
    try {
      s->begin(info);
    } catch (...) {
      throw std::runtime_error(stageText(*s) + currentExceptionText());
    }
  }
  for (auto& o : p.outputs) o->begin(info);
  removeSummaries();
  MetricsStream metrics_stream(opt.metrics_csv, log);
  // A failed frame's files from the outputs that did not write it this run are an earlier run's
  // (outputs before the failure wrote theirs: those are kept). Decided by who wrote, not by
  // modification times, which a coarse or skewed clock could misorder. Runs inside a frame's
  // failure: should it fail too (an output's frameFiles()), the run still goes on and every
  // output still ends.
  auto removeStaleFrameFiles = [&](const std::string& frame_id, const Frame* frame,
                                   std::size_t outputs_done) {
    try {
      for (std::size_t k = outputs_done; k < p.outputs.size(); ++k) {
        for (const auto& f : p.outputs[k]->frameFiles(frame_id, frame)) {
          std::error_code ec;
          const auto path = inOutputDir(f);
          if (std::filesystem::remove(path, ec))
            log << "  removed " << path.string() << ": not this run's (frame " << frame_id
                << " failed before its output wrote it)\n";
        }
      }
    } catch (...) {
      log << "warning: frame " << frame_id
          << ": an earlier run's files of this frame may be left, and pass for this run's: "
             "removing them failed: "
          << currentExceptionText() << "\n";
    }
  };

  // Timing slots: read, read wait, egomotion stages, grid, other stages, outputs, total.
  std::vector<std::string> slot_names = {"read", "read wait"};
  std::size_t first_non_ego = 0;
  while (first_non_ego < p.stages.size() && p.stage_kinds[first_non_ego] == PluginKind::kEgomotion)
    ++first_non_ego;
  for (std::size_t s = 0; s < first_non_ego; ++s) slot_names.push_back(p.stages[s]->name());
  slot_names.push_back("grid");
  for (std::size_t s = first_non_ego; s < p.stages.size(); ++s)
    slot_names.push_back(p.stages[s]->name());
  for (auto& o : p.outputs) slot_names.push_back("output:" + o->name());
  slot_names.push_back("total");
  // A writer of `@pose` promises a pose for every frame, and the stages that read it were let
  // through on that promise (the loaders' check): a frame it leaves without one fails, naming it,
  // rather than reaching them without a pose.
  auto declaresPose = [](const Plugin& pl) {
    const auto w = pl.writes();
    return std::find(w.begin(), w.end(), artefacts::kPose) != w.end();
  };
  const bool source_poses = declaresPose(*p.source);
  // Grid layers the source declares it receives made (Frame::grid): every frame must bring them.
  std::vector<std::string> source_layers;
  for (const auto& w : p.source->writes())
    if (!artefacts::isFrameArtefact(w)) source_layers.push_back(w);
  std::vector<bool> stage_poses;
  for (const auto& s : p.stages) stage_poses.push_back(declaresPose(*s));
  // Only a pose an egomotion stage wrote is its estimate: a stage that leaves the source's own
  // (one that only de-skews the points) would be scored as exact against the truth it equals.
  bool ego_sets_pose = false;
  for (std::size_t s = 0; s < first_non_ego; ++s) ego_sets_pose = ego_sets_pose || stage_poses[s];
  auto requirePose = [](const Frame& f) {
    if (!f.pose)
      throw std::runtime_error(
          "left frame " + f.id + " without a pose, though it declares that it writes '" +
          artefacts::kPose + "' (a pose for every frame, which later stages rely on)");
  };
  res.timings.resize(slot_names.size());
  for (std::size_t k = 0; k < slot_names.size(); ++k) res.timings[k].name = slot_names[k];

  // Two contexts: the current one and the previous frame's result (temporal fusion).
  Frame frames[2];
  TerrainGrid grids[2];
  FrameContext ctxs[2];
  int cur = 0;
  bool have_prev = false;
  Progress progress(n, stream, opt.progress);
  std::vector<double> slot_ms(slot_names.size());

  std::size_t depth = opt.read_ahead;
  if (depth == RunOptions::kAutoReadAhead)
    depth = !stream && p.source->concurrentReads()
                ? std::clamp<std::size_t>(std::thread::hardware_concurrency(), 1, 8)
                : 1;
  // Frames are held `depth` deep, but more threads than cores would only take turns.
  const std::size_t threads =
      std::min<std::size_t>(depth, std::max(1u, std::thread::hardware_concurrency()));
  FrameFeed feed(*p.source, first, stream ? opt.limit : n, depth, threads);
  res.read_ahead = feed.readAhead();
  res.read_threads = feed.readThreads();
  for (const auto& note : feed.notes()) log << "note: " << note << "\n";

  for (std::size_t k = 0;; ++k) {
    // Checked between frames only: a frame half through its outputs would leave some of its
    // files written and others not.
    if (const int sig = stopRequested()) {
      res.summary.stop_signal = sig;
      break;
    }
    const std::size_t i = first + k;
    const auto t_frame = Clock::now();
    FrameFeed::Taken got = feed.take(k);  // a stream's may wait for its frame
    if (got.end) {
      // A stream that ended because a stop interrupted it: the run was stopped, not complete.
      if (feed.interrupted()) res.summary.stop_signal = stopRequested();
      break;
    }
    std::string id = got.id;  // "" if frameId() or next() threw
    FrameContext& ctx = ctxs[cur];
    ctx = FrameContext{};
    ctx.frame = &frames[cur];
    ctx.grid = &grids[cur];
    ctx.labels = p.labels.get();
    ctx.index = i;
    ctx.previous = have_prev ? &ctxs[1 - cur] : nullptr;
    ctx.run = &run_state;
    std::size_t slot = 0;
    std::string stage_name = "read";
    std::size_t stages_done = 0;   // stages that processed this frame, in p.stages' order
    std::size_t outputs_done = 0;  // outputs that wrote this frame
    bool read_ok = false;          // frames[cur] holds this frame (its cameras name files)
    try {
      slot_ms[slot++] = got.read_ms;
      slot_ms[slot++] = got.wait_ms;
      if (got.error) std::rethrow_exception(got.error);
      frames[cur] = std::move(got.frame);
      auto t = Clock::now();
      if (frames[cur].id.empty()) frames[cur].id = id;
      read_ok = true;
      if (source_poses && !frames[cur].pose)
        throw InputError(frames[cur].source_path,
                         "has no pose, though source '" + p.source->name() + "' (" +
                             p.source->type() + ") declares that it writes '" + artefacts::kPose +
                             "' (a pose for every frame, which stages rely on)");
      noteDroppedPoints(frames[cur], res, log, opt.progress);
      // The grid is built after the egomotion stages; until then it would still hold the layers
      // of the frame two back (the slot's last use), which they could take for this frame's.
      if (first_non_ego > 0) grids[cur].reset(p.grid);
      // The source's truth, which the egomotion stages' pose is scored against: one that changed
      // it would be scored against itself.
      const std::optional<Eigen::Isometry3d> truth_pose = frames[cur].truth_pose;
      for (std::size_t s = 0; s < first_non_ego; ++s) {
        stage_name = p.stages[s]->name();
        t = Clock::now();
        p.stages[s]->process(ctx);
        ++stages_done;
        if (stage_poses[s]) requirePose(frames[cur]);
        slot_ms[slot++] = msSince(t);
        const auto& after = frames[cur].truth_pose;
        if (after.has_value() != truth_pose.has_value() ||
            (after && after->matrix() != truth_pose->matrix()))
          throw std::logic_error(
              "egomotion stage changed Frame::truth_pose, the source's ground truth; an "
              "estimate belongs in Frame::pose");
      }
      std::optional<PoseError> ego_error;
      if (ego_sets_pose && truth_pose && frames[cur].pose) {
        ego_error = poseError(*frames[cur].pose, *truth_pose);
        ctx.metrics["egomotion.translation_error_m"] = ego_error->translation_m;
        ctx.metrics["egomotion.rotation_error_deg"] = ego_error->rotation_deg;
      }
      stage_name = "grid";
      t = Clock::now();
      grids[cur].reset(p.grid);
      if (!source_layers.empty())
        adoptSourceGrid(*p.source, source_layers, frames[cur], grids[cur]);
      grids[cur].binPoints(frames[cur].points);
      noteCloudOutsideGrid(frames[cur], grids[cur], res, log, opt.progress);
      slot_ms[slot++] = msSince(t);
      for (std::size_t s = first_non_ego; s < p.stages.size(); ++s) {
        stage_name = p.stages[s]->name();
        t = Clock::now();
        p.stages[s]->process(ctx);
        ++stages_done;
        if (stage_poses[s]) requirePose(frames[cur]);
        slot_ms[slot++] = msSince(t);
      }
      for (auto& o : p.outputs) {
        stage_name = "output " + o->name();
        t = Clock::now();
        o->write(ctx);
        ++outputs_done;
        slot_ms[slot++] = msSince(t);
      }
      slot_ms[slot++] = msSince(t_frame);
      for (std::size_t s = 0; s < slot; ++s) res.timings[s].ms.push_back(slot_ms[s]);
      ++res.summary.frames_ok;
      if (ego_error) res.egomotion_error.add(*ego_error);
      if (!ctx.metrics.empty() && !metrics_stream.append(frames[cur].id, ctx.metrics))
        res.metrics.emplace_back(frames[cur].id, ctx.metrics);
      // Only one frame is kept back: its own `previous` is the slot the next frame reuses, so
      // left set it would point at the next frame itself.
      ctx.previous = nullptr;
      have_prev = true;
      cur = 1 - cur;
    } catch (...) {
      const std::string why = "[" + stage_name + "] " + currentExceptionText();
      // An id that names an earlier frame's files (a stream's): those are that frame's.
      const bool id_known = !id.empty() && !got.id_clash;
      if (id.empty()) id = "#" + std::to_string(i);  // frameId() or next() itself failed
      res.summary.failed.push_back({id, why});
      if (opt.progress) std::fprintf(stderr, "%s", ::isatty(2) ? "\n" : "");
      log << "frame " << id << " failed and was skipped: " << why << "\n";
      // A stateful stage (a map, a filter) takes back what it added for the frame.
      for (std::size_t s = 0; s < stages_done; ++s) {
        try {
          p.stages[s]->frameFailed(ctx);
        } catch (...) {
          log << "warning: frame " << id << ": " << stageText(*p.stages[s])
              << "could not take the failed frame back: " << currentExceptionText() << "\n";
        }
      }
      if (id_known) removeStaleFrameFiles(id, read_ok ? &frames[cur] : nullptr, outputs_done);
    }
    progress.update(k + 1, id, msSince(t_frame), res.summary.failed.size());
  }
  // Reads in progress finish and no other starts: frames read ahead are dropped, a stream's
  // next() under way is interrupted, and the reader threads are joined before the outputs end.
  feed.close();
  if (stream && first > 0 && res.summary.stop_signal == 0 &&
      res.summary.frames_ok + res.summary.failed.size() == 0)
    log << "note: the stream of source '" << p.source->type() << "' ended before frame " << first
        << " (--first " << first << " skips the frames before it): no frame was run\n";
  if (res.summary.stop_signal != 0) {
    if (opt.progress && ::isatty(2)) std::fprintf(stderr, "\n");
    log << "run " << interruptionText(res.summary) << "; ending the outputs\n";
  }

  // The stages end before the outputs, so an output's end() exports what a stage finished.
  res.summary.run = &run_state;
  for (auto& s : p.stages) {
    try {
      s->end(res.summary);
    } catch (...) {
      const std::string why = currentExceptionText();
      res.output_errors.push_back(stageText(*s) + why);
      log << stageText(*s) << "failed at the end: " << why << "\n";
    }
  }
  for (auto& o : p.outputs) {
    try {
      o->end(res.summary);
    } catch (...) {
      const std::string why = currentExceptionText();
      res.output_errors.push_back("output '" + o->name() + "': " + why);
      log << "output '" << o->name() << "' failed at the end: " << why << "\n";
    }
  }
  // Would dangle once the run returns.
  res.summary.run = nullptr;
  std::string metrics_error;
  res.metrics_file = metrics_stream.finish(metrics_error);
  if (!metrics_error.empty()) {
    log << "error: " << metrics_error << "\n";
    res.output_errors.push_back(metrics_error);
  }
  return res;
}

std::string timingTable(const RunResult& r) {
  std::ostringstream o;
  char buf[256];
  o << "| stage | mean [ms] | std [ms] | min [ms] | max [ms] | median [ms] |\n";
  o << "|---|---:|---:|---:|---:|---:|\n";
  for (const auto& t : r.timings) {
    if (t.ms.empty()) continue;
    std::string sd = "–";
    if (!std::isnan(t.stddev())) {
      std::snprintf(buf, sizeof buf, "%.3f", t.stddev());
      sd = buf;
    }
    std::snprintf(buf, sizeof buf, "| %s | %.3f | %s | %.3f | %.3f | %.3f |\n", t.name.c_str(),
                  t.mean(), sd.c_str(), t.min(), t.max(), t.median());
    o << buf;
  }
  if (r.read_threads > 0)
    o << "\nFrames were read up to " << r.read_ahead << " ahead on " << r.read_threads
      << " thread(s): read is each read's own time, read wait the part the run waited for, and "
         "total the run's time per frame (read wait included, the rest of the read not).\n";
  return o.str();
}

std::string egomotionErrorText(const RunResult& r) {
  const PoseErrorSummary& e = r.egomotion_error;
  if (e.frames == 0) return "";
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "egomotion against truth over %zu frame(s): translation mean %.3f m, max %.3f m; "
                "rotation mean %.3f°, max %.3f°",
                e.frames, e.translationMean_m(), e.translation_max_m, e.rotationMean_deg(),
                e.rotation_max_deg);
  return buf;
}

std::string metricsCsv(const RunResult& r) {
  std::ostringstream o;
  o.precision(9);
  o << kMetricsHeader;
  for (const auto& [frame, m] : r.metrics) appendMetricsRows(o, frame, m);
  return o.str();
}


void writeRunReports(const std::string& dir, const RunResult& r) {
  const std::string stopped = interruptionText(r.summary);
  writeFileAtomic(dir + "/" + kTimingFile,
                  (stopped.empty() ? "" : "Run " + stopped + ": timings of those only.\n\n") +
                      timingTable(r) +
                      (r.egomotion_error.frames ? "\n" + egomotionErrorText(r) + ".\n" : ""));
  // Always written, if only its header: an earlier run's file would pass for this one's.
  if (r.metrics_file != dir + "/" + kMetricsFile)
    writeFileAtomic(dir + "/" + kMetricsFile, metricsCsv(r));
}

}  // namespace terramrf
