#pragma once
// Plugin interfaces. A plugin is one shared library exporting one class through
// TERRAMRF_PLUGIN(...). The core finds it by type name, declares its parameters, validates the
// config against them, calls configure(), and then drives it per frame.
#include <map>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "terramrf/energy_model.hpp"
#include "terramrf/errors.hpp"
#include "terramrf/frame.hpp"
#include "terramrf/label_set.hpp"
#include "terramrf/params.hpp"
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

/// Yields frames. Random access by index so a batch can skip a bad frame and go on.
class Source : public Plugin {
 public:
  /// Number of frames.
  virtual std::size_t size() const = 0;
  /// Short id of frame i (file stem), known without reading it.
  virtual std::string frameId(std::size_t i) const = 0;
  /// Reads frame i. Throws InputError naming the file on bad data. The pipeline reads ahead on a
  /// thread of its own, so read() must not touch state the stages or outputs share.
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
};

/// Everything a stage sees for one frame. Stages read what earlier stages wrote.
struct FrameContext {
  Frame* frame = nullptr;
  TerrainGrid* grid = nullptr;
  const LabelSet* labels = nullptr;
  EnergyModel energy;
  OptimiserReport optimiser;
  std::size_t index = 0;  ///< position in the batch
  /// Result of the previous successfully processed frame (temporal fusion), or nullptr: its
  /// frame (pose included), grid (layers, labels, `score.<class>`), energy and report. One frame
  /// back only (its own `previous` is nullptr); a stage that needs more keeps its own state.
  const FrameContext* previous = nullptr;
  /// Scalars a stage wants reported (e.g. "preclass.obstacle_cells").
  std::map<std::string, double> metrics;
};

/// Feature, energy, optimiser and egomotion plugins: one work function per frame.
class Stage : public Plugin {
 public:
  virtual void process(FrameContext& ctx) = 0;
};

/// Information an output gets once per run.
struct RunInfo {
  std::string config_path;
  std::string output_dir;
  std::size_t frames = 0;
  const LabelSet* labels = nullptr;
  GridGeometry grid;
  /// The source's camera names (Source::cameraNames()); may be empty.
  std::vector<std::string> cameras;
};

struct RunSummary {
  std::size_t frames_ok = 0;
  std::vector<std::pair<std::string, std::string>> failed;  ///< frame id, reason
  /// Frames the run was to take (RunInfo::frames).
  std::size_t frames_total = 0;
  /// Non-zero when the run was asked to stop (the signal: SIGINT, SIGTERM; stop_request.hpp) and
  /// took no frame after its frames_ok + failed.size(). end() still runs: a summary it writes
  /// covers those frames only and should say so (interruptionText()).
  int stop_signal = 0;
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
  /// fixed-size Eigen member (Frame: 528 → 576 bytes), which the version string cannot show;
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
      X(OptimiserReport) X(FrameContext) X(PluginContext) X(RunInfo) X(RunSummary)
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
