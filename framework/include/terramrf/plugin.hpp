#pragma once
// Plugin interfaces. A plugin is one shared library exporting one class through
// TERRAMRF_PLUGIN(...). The core finds it by type name, declares its parameters, validates the
// config against them, calls configure(), and then drives it per frame.
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "terramrf/energy_model.hpp"
#include "terramrf/errors.hpp"
#include "terramrf/frame.hpp"
#include "terramrf/label_set.hpp"
#include "terramrf/params.hpp"
#include "terramrf/run_state.hpp"
#include "terramrf/terrain_grid.hpp"
#include "terramrf/version.hpp"

namespace terramrf {

enum class PluginKind { kSource, kEgomotion, kFeature, kEnergy, kOptimiser, kOutput };
const char* toString(PluginKind k);

/// Pseudo-layers for the read/write check: the grid's point lists (written by the runner's grid
/// builder), the energy model (written by an energy stage), the label layer, the cameras' pixels
/// per cell, and the frame's pose.
///
/// The pose is a frame artefact: it lives on the Frame, which exists from the source on. The
/// others, like every grid layer, exist only once the grid is built, after the egomotion stages.
/// So a source can provide frame artefacts only, and an egomotion stage can read and write frame
/// artefacts only; the loaders refuse the rest (docs/architecture.md, "Reads and writes").
///
/// A plugin that lists `@pose` in writes() sets Frame::pose on every frame (a source that cannot
/// for some frame throws InputError for it), so a stage that lists `@pose` in reads() may rely on
/// it: the loaders refuse it when neither the source nor an earlier stage writes one.
namespace artefacts {
inline constexpr const char* kPoints = "@points";
inline constexpr const char* kEnergy = "@energy";
inline constexpr const char* kLabels = "@labels";
inline constexpr const char* kPose = "@pose";               ///< Frame::pose, set on every frame
inline constexpr const char* kCellPixels = "@cell_pixels";  ///< TerrainGrid::cellPixels()
/// True for what lives on the Frame rather than on the grid (the pose).
inline bool isFrameArtefact(const std::string& name) { return name == kPose; }
}  // namespace artefacts

/// Layer names by convention. An optimiser that can score its labelling writes one layer per
/// active class, `score.<class name>`, higher = more confident (Gibbs: marginal probability;
/// deterministic optimisers: a monotone map of the energy margin). ROC curves read them.
namespace layers {
inline std::string score(const std::string& class_name) { return "score." + class_name; }
}  // namespace layers

/// What a plugin may know about the run when it is configured.
struct PluginContext {
  std::string config_dir;  ///< folder of the config file; relative paths resolve against it
  std::string output_dir;  ///< where outputs go (created by the runner)
  GridGeometry grid;       ///< the configured grid
  const LabelSet* labels = nullptr;
  /// How each grid layer written by the stages before this plugin is computed, so a model can
  /// record it and an energy can check it was learnt on the same: layer → flow YAML
  /// {stage: type, cell_m: grid cell size [m], params: {…all parameters…}, inputs: {layer read:
  /// its origin}}. Null where the plugin is configured outside a pipeline.
  const std::map<std::string, std::string>* layer_origins = nullptr;
  /// Resolves a path relative to config_dir (absolute paths unchanged).
  std::string resolve(const std::string& path) const;
};

class Plugin {
 public:
  virtual ~Plugin() = default;
  /// Binds parameters to members (see ParamDecl). Called once, before configure().
  virtual void declare(ParamDecl& /*params*/) {}
  /// Called after parameters are set: cross-checks and set-up. Throw ParamError(name, why).
  virtual void configure(const PluginContext& /*ctx*/) {}
  /// Grid layers (or artefacts::*) this stage needs from earlier stages / writes.
  virtual std::vector<std::string> reads() const { return {}; }
  virtual std::vector<std::string> writes() const { return {}; }

  /// Instance name from the config (`name:`; defaults to the type).
  const std::string& name() const { return name_; }
  const std::string& type() const { return type_; }
  void setIdentity(std::string name, std::string type) {
    name_ = std::move(name);
    type_ = std::move(type);
  }

 private:
  std::string name_, type_;
};

/// Yields frames, as a batch or as a stream (streaming(), asked once the source is configured).
///
/// A batch (the default) is finite, indexed before the run and read by index: size(), frameId(i)
/// without reading, read(i). The runner checks before the first frame that no two ids name the
/// same files, reads ahead (several frames at once if concurrentReads()), skips a bad frame by
/// its index and says "k of n". `compare` and `train` take batches only: they read each frame
/// many times and split the frames by index.
///
/// A stream yields frames as they come (LCM channels live, a log replayed by another process):
/// next() in order, each frame with its own Frame::id, until it returns std::nullopt; how many
/// there will be is unknown (RunInfo::frames and RunSummary::frames_total are 0). The runner
/// calls next() from one thread at a time (a reader thread of its own, or its own thread with
/// --read-ahead 0), checks each id against the earlier frames' as the frame comes, and calls
/// interrupt() from another thread when a stop is requested (SIGINT, SIGTERM: stop_request.hpp)
/// so that a next() waiting for a message returns. size(), frameId(), read() and
/// concurrentReads() are never called on a stream; StreamSource is the base of a stream-only
/// source.
class Source : public Plugin {
 public:
  /// Number of frames (a batch).
  virtual std::size_t size() const = 0;
  /// Short id of frame i (file stem), known without reading it (a batch).
  virtual std::string frameId(std::size_t i) const = 0;
  /// Reads frame i (a batch). Throws InputError naming the file on bad data. The pipeline reads
  /// ahead on a thread of its own, so read() must not touch state the stages or outputs share.
  virtual Frame read(std::size_t i) = 0;
  /// True if read(i) and read(j) may run at the same time on different threads (read changes no
  /// state). The pipeline then reads several frames at once; otherwise one after another, in
  /// order. Frames reach the stages in order either way.
  virtual bool concurrentReads() const { return false; }
  /// Names of the cameras its frames carry (CameraModel::name), known without reading a frame;
  /// empty if none, or if they are known only from the files read. Outputs name their camera
  /// images with them, so a frame that fails before it is read still has an earlier run's
  /// camera images removed (RunInfo::cameras).
  virtual std::vector<std::string> cameraNames() const { return {}; }
  /// How each grid layer the source brings made (declared in writes()) was computed, as
  /// PluginContext::layer_origins records it for stages (layer -> origin record), for the layers
  /// whose origins came with them (an LCM log's layer_origins_t); empty when unknown. Asked
  /// after configure(). The pipeline adds them to PluginContext::layer_origins, so a model is
  /// checked against received layers as against computed ones.
  virtual std::map<std::string, std::string> layerOrigins() const { return {}; }

  /// True if the frames come through next() rather than read(i). Asked after configure(), so
  /// one plugin may be either, as its parameters say (a log indexed in advance, or followed live).
  virtual bool streaming() const { return false; }
  /// A stream's next frame, in arrival order, waiting for it if need be; std::nullopt once the
  /// stream has ended (and on every call after), and promptly once interrupt() was called.
  /// Frame::id must be set and distinct: a frame whose id names the same files as an earlier
  /// frame's (safeFileName) fails, so that it cannot write over that frame's outputs. Throws
  /// (InputError) for a frame that cannot be had, a damaged message: that frame fails, named
  /// `#<position>`, and next() is called again, so a stream that cannot go on (its log ended
  /// short, its connection lost for good) returns std::nullopt rather than throw on every call.
  /// Like read(), it runs on a reader thread and must not touch state the stages or outputs
  /// share. The default, for a batch, throws std::logic_error: the runner never calls it there.
  virtual std::optional<Frame> next();
  /// Ends the stream early: a next() waiting now or called later returns std::nullopt promptly
  /// (within a fraction of a second). Called from another thread than next(), possibly while it
  /// waits, possibly more than once or after the stream ended, so it must be thread-safe and
  /// idempotent (an atomic flag and a condition variable or a self-pipe the wait also watches).
  /// The runner calls it when a stop is requested and when it wants no further frame while a
  /// next() is under way. Without it a stream that waits ignores Ctrl-C until a frame comes.
  /// The default does nothing: enough for a batch and for a stream whose next() never waits.
  virtual void interrupt() {}
};

/// Base of a source that is only ever a stream: next() and interrupt() to write, no index. The
/// batch functions are final here and the runner never calls them on a stream: size() is 0,
/// concurrentReads() false, and frameId() and read() throw std::logic_error.
class StreamSource : public Source {
 public:
  bool streaming() const final { return true; }
  std::optional<Frame> next() override = 0;
  /// Required: a stream that waits for its frames must let a stop request end the wait.
  void interrupt() override = 0;

  std::size_t size() const final { return 0; }
  std::string frameId(std::size_t i) const final;
  Frame read(std::size_t i) final;
  bool concurrentReads() const final { return false; }
};

/// Everything a stage sees for one frame. Stages read what earlier stages wrote.
struct FrameContext {
  Frame* frame = nullptr;
  TerrainGrid* grid = nullptr;
  const LabelSet* labels = nullptr;
  EnergyModel energy;
  OptimiserReport optimiser;
  std::size_t index = 0;  ///< position in the batch, or in the stream (frames skipped included)
  /// Result of the previous successfully processed frame (temporal fusion), or nullptr: its
  /// frame (pose included), grid (layers, labels, `score.<class>`), energy and report. One frame
  /// back only (its own `previous` is nullptr); a stage that needs more keeps its own state, or
  /// puts it in `run`.
  const FrameContext* previous = nullptr;
  /// Scalars a stage wants reported (e.g. "preclass.obstacle_cells").
  std::map<std::string, double> metrics;
  /// The run's persistent state (maps built over the frames), the same for every frame of a
  /// run. Set by the runner for every frame; nullptr only where stages are driven by hand.
  RunState* run = nullptr;
};

/// Information a stage and an output get once per run.
struct RunInfo {
  std::string config_path;
  std::string output_dir;
  /// Frames the run is to take; 0 when unknown: a stream (Source::streaming()), or an empty batch.
  std::size_t frames = 0;
  const LabelSet* labels = nullptr;
  GridGeometry grid;
  /// The source's camera names (Source::cameraNames()); may be empty.
  std::vector<std::string> cameras;
  /// The run's persistent state, empty at begin(): stages make their maps in it (outputs only
  /// read). nullptr where an output is driven outside runPipeline (`train`'s feature_stats,
  /// which spans the runs of several items).
  RunState* run = nullptr;
};

struct RunSummary {
  std::size_t frames_ok = 0;
  std::vector<std::pair<std::string, std::string>> failed;  ///< frame id, reason
  /// Frames the run was to take (RunInfo::frames); 0 when unknown (a stream): say "k frames",
  /// not "k of 0".
  std::size_t frames_total = 0;
  /// Non-zero when the run was asked to stop (the signal: SIGINT, SIGTERM; stop_request.hpp) and
  /// took no frame after its frames_ok + failed.size(). end() still runs: a summary it writes
  /// covers those frames only and should say so (interruptionText()).
  int stop_signal = 0;
  /// The run's persistent state as the stages' end() left it, so that an output can export a map
  /// built over every frame, the last included. nullptr where an output is driven outside
  /// runPipeline (see RunInfo::run).
  const RunState* run = nullptr;
};

/// Feature, energy, optimiser and egomotion plugins: one work function per frame, and hooks
/// around the run for those that keep state over it (a map, a filter). The runner calls, in
/// order: every stage's begin() (config order), every output's begin(), then per frame
/// process() of each stage and write() of each output, then every stage's end() (config order)
/// and every output's end(), so that an output can export at its end what a stage finished.
class Stage : public Plugin {
 public:
  /// Once per run, before the first frame (RunInfo::run: the run's state, where a stage may make
  /// its maps). A throw fails the run before any frame, as `stage '<name>' (<type>): <what>`,
  /// and then no stage or output ends (nor when an output's begin() throws after the stages
  /// began): a stage that takes a resource in begin() releases it in its destructor too.
  virtual void begin(const RunInfo& /*info*/) {}
  virtual void process(FrameContext& ctx) = 0;
  /// Called when a frame this stage processed fails in a later stage or output (not when this
  /// stage's own process() threw, nor for stages after the failing one): the frame is skipped,
  /// so what process() added for it (a map update, a filter's prediction) should be taken back.
  /// `ctx` is that frame's context. The next frame's `previous` stays the last frame that
  /// succeeded, so a frame missing in between shows as ctx.index − previous->index > 1 (frames
  /// that fail before any stage, in the read, are never processed and show only that way). A
  /// throw from here is logged and the run goes on.
  virtual void frameFailed(const FrameContext& /*ctx*/) {}
  /// Once per run, after the last frame, also when the run was interrupted (summary.stop_signal)
  /// and before any output's end(). Files written here must be atomic. A throw is reported as
  /// the outputs' are (RunResult::output_errors, exit status 4); the other stages and the
  /// outputs still end.
  virtual void end(const RunSummary& /*summary*/) {}
};

class Output : public Plugin {
 public:
  virtual void begin(const RunInfo& /*info*/) {}
  /// Called after the stages for each frame that succeeded.
  virtual void write(const FrameContext& ctx) = 0;
  /// Called once at the end (e.g. evaluation totals). Files written here must be atomic.
  virtual void end(const RunSummary& /*summary*/) {}
  /// The files write() may make for frame `frame_id` (absolute, or relative to the run's output
  /// folder): exact names, never a pattern, since one frame's id may begin another's ("a",
  /// "a_b"). When the frame fails, the runner removes those an earlier run left there, so they
  /// cannot pass for this run's. `frame` is the failed frame as read (its cameras name camera
  /// images), or nullptr if reading it failed; camera names from RunInfo::cameras and from the
  /// frames written so far then stand in.
  virtual std::vector<std::string> frameFiles(const std::string& /*frame_id*/,
                                              const Frame* /*frame*/) const {
    return {};
  }
  /// The files end() makes. The runner removes them before the first frame: a run that stops
  /// early leaves none of an earlier run's summaries beside its own resolved config.
  virtual std::vector<std::string> summaryFiles() const { return {}; }
};

// ---- registration -------------------------------------------------------------------------

/// Size and alignment of one core type as a plugin's compiler laid it out [bytes].
struct TypeLayout {
  const char* name;
  std::size_t size_bytes;
  std::size_t align_bytes;
};

struct PluginDescriptor {
  PluginKind kind;
  const char* type;     ///< type name used in configs
  const char* summary;  ///< one line for `terramrf plugins`
  Plugin* (*create)();
  /// How the plugin's compiler laid out the core types it is handed. Another -m flag (-mavx,
  /// -march=native) raises Eigen's static alignment and so the size of every type holding a
  /// fixed-size Eigen member (Frame: 976 → 1056 bytes), which the version string cannot show;
  /// the loader compares these with its own and refuses a library that differs.
  int eigen_max_static_align_bytes;  ///< EIGEN_MAX_STATIC_ALIGN_BYTES [bytes]
  const TypeLayout* layouts;
  std::size_t layout_count;
};

namespace detail {
/// True if `C` derives from the base class a plugin of kind `k` is used as.
template <class C>
constexpr bool derivesFromKindBase(PluginKind k) {
  switch (k) {
    case PluginKind::kSource:
      return std::is_base_of_v<Source, C>;
    case PluginKind::kOutput:
      return std::is_base_of_v<Output, C>;
    case PluginKind::kEgomotion:
    case PluginKind::kFeature:
    case PluginKind::kEnergy:
    case PluginKind::kOptimiser:
      return std::is_base_of_v<Stage, C>;
  }
  return false;
}
}  // namespace detail

}  // namespace terramrf

/// The core types a plugin is handed, whose layout plugin and core must agree on. X(type) each.
#define TERRAMRF_PLUGIN_LAYOUT_TYPES(X)                                                            \
  X(PointCloud)                                                                                    \
  X(CameraModel) X(CameraImage) X(Frame) X(GridGeometry) X(TerrainGrid) X(LabelSet) X(EnergyModel) \
      X(OptimiserReport) X(FrameContext) X(PluginContext) X(RunInfo) X(RunSummary) X(RunState)
#define TERRAMRF_PLUGIN_LAYOUT_ENTRY(T) \
  ::terramrf::TypeLayout{#T, sizeof(::terramrf::T), alignof(::terramrf::T)},

#define TERRAMRF_PLUGIN_ABI_SYMBOL terramrf_plugin_abi
#define TERRAMRF_PLUGIN_DESCRIPTOR_SYMBOL terramrf_plugin_descriptor

/// Exports `Class` as plugin `type_name` of `kind` (a terramrf::PluginKind). One per library.
/// The layouts are measured here, in the plugin's own translation unit and with its flags (an
/// inline function of the core's could be bound to the core's copy at load time).
#define TERRAMRF_PLUGIN(Class, kind, type_name, summary)                                      \
  static_assert(::terramrf::detail::derivesFromKindBase<Class>(kind),                         \
                "TERRAMRF_PLUGIN(" #Class ", " #kind                                          \
                ", ...): the class must derive from the "                                     \
                "base class of its kind: terramrf::Source for kSource, terramrf::Output for " \
                "kOutput, terramrf::Stage for kEgomotion, kFeature, kEnergy and kOptimiser"); \
  extern "C" __attribute__((visibility("default"))) const char* terramrf_plugin_abi() {       \
    return TERRAMRF_ABI_STRING;                                                               \
  }                                                                                           \
  extern "C" __attribute__((visibility("default"))) const ::terramrf::PluginDescriptor*       \
  terramrf_plugin_descriptor() {                                                              \
    static const ::terramrf::TypeLayout layouts[] = {                                         \
        TERRAMRF_PLUGIN_LAYOUT_TYPES(TERRAMRF_PLUGIN_LAYOUT_ENTRY)};                          \
    static const ::terramrf::PluginDescriptor d{                                              \
        kind,                                                                                 \
        type_name,                                                                            \
        summary,                                                                              \
        []() -> ::terramrf::Plugin* { return new Class(); },                                  \
        EIGEN_MAX_STATIC_ALIGN_BYTES,                                                         \
        layouts,                                                                              \
        sizeof(layouts) / sizeof(layouts[0])};                                                \
    return &d;                                                                                \
  }
