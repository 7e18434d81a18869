#pragma once
// Runs a loaded pipeline over every frame of its source: read → egomotion → grid → stages →
// outputs. Owns order, per-stage timing and error handling; a bad frame is reported and skipped.
#include <iosfwd>
#include <map>
#include <string>
#include <vector>

#include "terramrf/config.hpp"

namespace terramrf {

struct StageTiming {
  std::string name;         ///< stage instance name ("read", "grid" for the runner's own steps)
  std::vector<double> ms;   ///< one entry per processed frame [ms]
  double mean() const;
  /// Sample standard deviation (n − 1) [ms]; NaN with fewer than two frames.
  double stddev() const;
  double min() const;
  double max() const;
  double median() const;
};

/// How far a pose estimate is from the truth.
struct PoseError {
  double translation_m = 0;  ///< distance between the two positions [m]
  double rotation_deg = 0;   ///< angle of the rotation R_truthᵀ · R_estimate [deg]
};
PoseError poseError(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth);

/// Mean and max of the PoseErrors of a run's frames.
struct PoseErrorSummary {
  std::size_t frames = 0;  ///< frames scored
  double translation_sum_m = 0, translation_max_m = 0;
  double rotation_sum_deg = 0, rotation_max_deg = 0;
  void add(const PoseError& e);
  double translationMean_m() const;  ///< NaN when no frame was scored
  double rotationMean_deg() const;   ///< NaN when no frame was scored
};

struct RunOptions {
  bool progress = true;          ///< progress bar on stderr
  std::ostream* log = nullptr;   ///< where failures and the summary go (default std::cerr)
  /// First frame index; a stream's first `first` frames are read and dropped.
  std::size_t first = 0;
  std::size_t limit = 0;  ///< frames to run at most; 0 = all frames (a stream: until it ends)
  /// Frames read ahead of the one being processed, on reader threads: 0 reads each frame on the
  /// calling thread when it is needed; kAutoReadAhead is 1 for a source that reads one frame at
  /// a time and the number of hardware threads (≤ 8) for one that allows concurrent reads.
  /// A stream is read ahead on one thread, whatever the depth. Results do not depend on it.
  std::size_t read_ahead = kAutoReadAhead;
  static constexpr std::size_t kAutoReadAhead = static_cast<std::size_t>(-1);
  /// Where the stages' metrics go as each frame completes (`<metrics_csv>.partial`, renamed to
  /// `metrics_csv` when the run ends), so that a long run or a stream keeps none of them in
  /// memory and a killed run leaves the rows it had. "" keeps them in RunResult::metrics.
  std::string metrics_csv;
};

struct RunResult {
  RunSummary summary;
  /// Frames the run was to take (RunSummary::frames_total); 0 when unknown (a stream).
  std::size_t frames_total = 0;
  /// read, read wait, egomotion…, grid, stages…, outputs…, total. "read" is the read's own
  /// duration, "read wait" the part of it the run waited for (less when reads ran ahead), and
  /// "total" the run's time per frame from its wait for the frame to its last output.
  std::vector<StageTiming> timings;
  std::size_t read_ahead = 0;    ///< frames read ahead (0: read when needed)
  std::size_t read_threads = 0;  ///< reader threads (0: read on the calling thread)
  /// Failures at the end of the run: each output's end() (`output '<name>': <what>`) and each
  /// stage's end() (`stage '<name>' (<type>): <what>`), in the order they ended.
  std::vector<std::string> output_errors;
  /// Points the source dropped while reading, over the frames read (Frame::dropped_*_points).
  std::size_t points_dropped_nonfinite = 0;
  std::size_t points_dropped_no_return = 0;
  /// Frames read with no usable point (an empty file, or every point dropped): classified as
  /// all-unknown, not failed, and listed here so that it is not mistaken for a clear road.
  std::vector<std::string> empty_frames;
  /// Frames with points of which under 1 % fall inside the grid (a cloud in a map frame, far from
  /// the sensor-centred grid): all or nearly all cells unknown, warned about and listed here.
  std::vector<std::string> frames_outside_grid;
  /// What the stages measured (FrameContext::metrics, e.g. "rough.sorted_rings"), per frame that
  /// completed, in run order; frames whose stages measured nothing are left out.
  std::vector<std::pair<std::string, std::map<std::string, double>>> metrics;
  /// The file the metrics went to as the frames completed (RunOptions::metrics_csv); "" when
  /// they are in `metrics` (not asked for, or the file could not be written: then `metrics`
  /// holds the rows from the failure on, and output_errors says the file is incomplete, naming
  /// the partial file with the rows before).
  std::string metrics_file;
  /// The egomotion stages' poses against the source's truth, over the frames that completed
  /// with both (Frame::pose after those stages, Frame::truth_pose); also each such frame's
  /// metrics egomotion.translation_error_m and egomotion.rotation_error_deg. No frame is scored
  /// in a pipeline without egomotion stages: there `pose` is the source's own.
  PoseErrorSummary egomotion_error;
  /// 0 all frames ok (or none: an empty batch or stream); 3 some frames failed; 4 every frame
  /// failed or a stage or an output failed at the end (output_errors);
  /// 128 + the signal (130 SIGINT, 143 SIGTERM, as a shell reports a process the signal ended)
  /// when the run was interrupted (summary.stop_signal), whatever else happened.
  int exitCode() const;
};

/// Runs every frame (a stream's until next() returns std::nullopt, or --limit), or stops taking
/// frames once a stop is requested (stop_request.hpp: SIGINT, SIGTERM), after the frame in hand;
/// a stream waiting for its next frame is interrupted at once (Source::interrupt()). Every
/// stage's and output's end() runs either way. Each call makes a new RunState (run_state.hpp)
/// for the stages and outputs, empty at their begin() and gone when it returns. Throws, before
/// any frame, if a stage's or an output's begin() does (a stage's as
/// `stage '<name>' (<type>): <what>`), or if two of a batch's frames would write the same files
/// (a stream frame that would is failed). Before the first frame it removes temporaries that
/// killed writers left in the output folder (removeStaleTemps).
RunResult runPipeline(Pipeline& pipeline, const RunOptions& options = {});

/// Per-stage timing table (mean, std, min, max, median per scan [ms]), Markdown.
std::string timingTable(const RunResult& r);

/// "egomotion against truth over N frame(s): translation mean … m, max … m; rotation mean …°,
/// max …°", or "" when no frame was scored (RunResult::egomotion_error).
std::string egomotionErrorText(const RunResult& r);

/// The stage metrics as CSV: `frame,metric,value`, one row per frame and metric.
std::string metricsCsv(const RunResult& r);

/// Writes `timing.md` and `metrics.csv` (if only its header; not when the run streamed it there,
/// RunResult::metrics_file) into `dir` (atomically, like every output); the timing of an
/// interrupted run says so in its first line, and the egomotion's error against the truth
/// (egomotionErrorText) follows the table when frames were scored.
void writeRunReports(const std::string& dir, const RunResult& r);

}  // namespace terramrf
