#pragma once
#include <map>
// Internal to the framework (not installed): the parts of config loading that the other readers of
// pipeline-like files (train configs and sweeps, sweep_*.cpp) share with loadPipeline, so that
// they check entries the same way and word problems alike.
#include <yaml-cpp/yaml.h>

#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "terramrf/config.hpp"
#include "terramrf/plugin.hpp"
#include "terramrf/registry.hpp"

namespace terramrf::detail {

/// Problems found in one file, reported all at once as a ConfigError.
struct Diags {
  std::string file;
  std::vector<Diagnostic> list;
  /// `stage` and `type` name the plugin entry the problem is in ("" = none).
  void add(const YAML::Mark& m, const std::string& msg, const std::string& stage = "",
           const std::string& type = "");
  void throwIfAny() const;
};

/// Top-level keys of a pipeline config (`terramrf run` and `terramrf train` read the same files).
extern const std::vector<std::string> kPipelineKeys;

/// What an unknown-key diagnostic suggests.
enum class KeyHint {
  kNearest,       ///< "(did you mean 'x'?)" when an allowed key is close
  kNearestOrAll,  ///< that, else "(expected one of: a, b, c)"
};

/// Reports every key of `map` that is not in `allowed` ("unknown key 'k' in <what>").
void checkKeys(Diags& d, const YAML::Node& map, const std::vector<std::string>& allowed,
               const std::string& what, KeyHint hint = KeyHint::kNearest,
               const std::string& stage = "", const std::string& type = "");

/// A new map holding the very key and value nodes of `map`, so diagnostics on it keep their file
/// positions (YAML::Clone loses them). Entries may be added to it or removed from it without
/// touching `map`; to replace one, remove it first — assigning to a shared entry would write
/// through to `map`. A null or non-map `map` gives an empty map.
YAML::Node copyMapKeepingPositions(const YAML::Node& map);

/// A plugin entry {name, type, params} as new maps (the entry and its params) over the file's
/// own nodes: errors keep their positions (a YAML::Clone's all stand at 1:1), and keys can be
/// set in the copy without touching the file's nodes — remove a key before setting it again, as
/// assigning to a shared node would rewrite it. `params` is an empty map if the entry has none,
/// and left as it is (shared) if it is not a map, for the caller to report.
YAML::Node copyEntryKeepingPositions(const YAML::Node& entry);

/// Where to point at the value of `key` in `map`: the value's position, or the key's when the
/// value is empty (yaml-cpp places an empty value at the next token, often the next line's key).
YAML::Mark valueMark(const YAML::Node& map, const std::string& key);

/// A deep copy in which no two places share a node. YAML::Clone keeps the file's aliases (`*p`
/// is the node `&p` names), so a value set at one use would be set at every other.
YAML::Node unaliasedCopy(const YAML::Node& n);

/// Reports every repeated key of every map under `n` at the repeat.
void checkDuplicateKeys(const YAML::Node& n, Diags& d);

/// The YAML of `path`; a missing file ("<what> does not exist") or a syntax error throws
/// ConfigError; repeated keys are added to `d`.
YAML::Node loadYamlFile(const std::string& path, Diags& d, const std::string& what);

/// Throws unless `root` is a map: an empty file (or one of comments only) says so, since it has
/// no position to point at; anything else gets `expected` at its position.
void requireTopLevelMap(const YAML::Node& root, Diags& d, const std::string& expected);

/// What a file is meant to be, judged from its top-level keys.
enum class FileKind { kPipeline, kSweep };

/// A pipeline config given where a sweep is expected, or the other way round, would otherwise
/// come back as a dozen unknown and missing keys; this reports it once, naming the command that
/// reads it, and throws. A file that looks like neither is left to the caller's key checks.
void refuseOtherKind(const YAML::Node& root, FileKind expected, Diags& d);

/// `version: 1` is required.
void checkVersion(const YAML::Node& root, Diags& d);

/// Keys every pipeline-like file has: plugin_path, grid, labels.
struct CommonKeys {
  GridGeometry grid;
  std::shared_ptr<LabelSet> labels = std::make_shared<LabelSet>(LabelSet::defaults());
  bool custom_labels = false;            ///< `labels:` given and valid
  std::vector<std::string> plugin_dirs;  ///< absolute; already prepended to the registry
};

/// Reads plugin_path (folders relative to `base_dir`, prepended to `reg`), grid and labels;
/// `hint` for unknown keys of `grid`.
CommonKeys readCommonKeys(const YAML::Node& root, const std::string& base_dir,
                          PluginRegistry& reg, Diags& d, KeyHint hint = KeyHint::kNearest);

/// Keys of a plugin entry.
extern const std::vector<std::string> kEntryKeys;  // name, type, params

/// "feature/energy" for messages.
std::string kindList(const std::vector<PluginKind>& kinds);

/// How createEntryPlugin checks an entry beyond its shape and type.
struct EntryChecks {
  KeyHint key_hint = KeyHint::kNearest;  ///< for unknown keys of the entry
  bool key_errors_name_the_stage = true;  ///< unknown keys are reported against the entry's name
  std::set<std::string>* unique_names = nullptr;  ///< reports a name already in it, then adds it
};

/// A plugin entry `{name, type, params}`, its plugin created but not yet parameterised.
struct EntryPlugin {
  std::unique_ptr<Plugin> plugin;  ///< identity set; null if there was a problem
  std::string name, type;          ///< the name defaults to the type
  PluginKind kind = PluginKind::kFeature;
  /// The type is not installed. Not reported: a config must have it, a sweep may skip the runs
  /// that need it, so the caller words it. `suggestion` is the nearest installed type, if any.
  bool unknown_type = false;
  std::string suggestion;
};

/// Checks entry `e` of `section` (a map with known keys and a type of one of `kinds`) and creates
/// its plugin. Every problem except an unknown type becomes a diagnostic at the entry.
EntryPlugin createEntryPlugin(PluginRegistry& reg, const YAML::Node& e, const std::string& section,
                              const std::vector<PluginKind>& kinds, Diags& d,
                              const EntryChecks& checks = {});

/// Sets the plugin's parameters from the entry's `params` (then `overrides`) and configures it;
/// problems become diagnostics against the plugin. Returns true if there were none.
bool applyEntryParams(Plugin& plugin, const YAML::Node& e, const PluginContext& ctx, Diags& d,
                      const std::vector<std::pair<std::string, std::string>>& overrides = {});

/// Records how `stage` computes each layer it writes (artefacts `@…` left out) on cells of
/// `cell_m`, as PluginContext::layer_origins describes: flow YAML {stage: type, cell_m, params:
/// {…}, inputs: {layer: origin}}, the inputs being the layers it reads that earlier stages wrote.
void recordLayerOrigins(Plugin& stage, double cell_m, std::map<std::string, std::string>& origins);
/// Records the origins source `s` knows of the grid layers it brings made (Source::layerOrigins,
/// only layers it declares in writes()), so a model is checked against received layers too.
void recordSourceOrigins(const Source& s, std::map<std::string, std::string>& origins);

/// The check of a pipeline's plugins in the order they run, one for run configs (loadPipeline),
/// for the pipelines that sweeps and train configs assemble (sweep_detail::assemble) and for a
/// sweep's feature sets as it is loaded (loadSweep), so that all accept and refuse alike. Walks
/// the source, the stages, then the outputs, as the runner runs them: the frame is read, the
/// leading egomotion stages change it, the grid is built from its points (`@points`), the other
/// stages fill the grid. Reports at the entry:
///  - an egomotion stage after a feature, energy or optimiser stage: the runner runs only the
///    leading egomotion stages before the grid is built (runPipeline), so a later one's changes
///    to the points and the pose would never reach the grid;
///  - a read that nothing before it writes. The source's writes count from the first stage on;
///    before the grid is built only frame artefacts (artefacts::isFrameArtefact: the pose) exist;
///  - a read or write of anything but a frame artefact by an egomotion stage (the grid does not
///    exist yet, and is built anew after it), and a source that declares `@points`, `@energy` or
///    `@cell_pixels` (the runner and stages make them; grid layers and `@labels` a source may
///    bring made, as Frame::grid).
class StageFlow {
 public:
  explicit StageFlow(Diags& d);
  /// The pipeline's source, `m` its entry. Not called when the source is not known (a sweep's
  /// feature sets are checked as it loads, before their items' sources are made, and again with
  /// each run's source; a source that could not be made): reads of frame artefacts are then not
  /// judged.
  void source(const Source& s, const YAML::Mark& m);
  /// Only the grid layers (and label layer) source `s` brings made, the source itself left
  /// unjudged as when it is not known: a sweep's feature set checked against each of its items'
  /// sources, whose frame artefacts each run's own check judges.
  void sourceLayers(const Source& s);
  /// The next stage, `kind` being its plugin's kind; `m` is its entry.
  void stage(const Plugin& p, PluginKind kind, const YAML::Mark& m);
  /// An output, after every stage.
  void output(const Plugin& p, const YAML::Mark& m);
  /// An entry that could not be made: what it would have written is unknown, so reads that miss
  /// it are no longer reported (they would only repeat its error).
  void entryFailed() { an_entry_failed_ = true; }
  /// A source that could not be made: what it brings (grid layers made elsewhere, `@labels`) is
  /// unknown, so reads of those are no longer reported; reads of what only stages make
  /// (`@energy`, `@cell_pixels`) still are.
  void sourceFailed() { source_failed_ = true; }

 private:
  void checkRead(const Plugin& p, const std::string& r, const YAML::Mark& m);
  void addWrite(const std::string& w);
  /// From the first stage that is not a leading egomotion stage on: the grid and its point lists.
  void buildGrid();
  std::string availableText() const;

  Diags& d_;
  bool an_entry_failed_ = false;
  bool source_failed_ = false;
  bool grid_built_ = false;
  std::string source_;         ///< "source 'name' (type)"; empty while the source is not known
  std::string first_non_ego_;  ///< "'name' (type)" of the first feature/energy/optimiser stage
  std::set<std::string> available_;
  std::vector<std::string> available_order_;  ///< for messages, in the order written
};

}  // namespace terramrf::detail
