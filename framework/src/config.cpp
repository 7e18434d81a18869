#include "terramrf/config.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>

#include "config_internal.hpp"
#include "param_yaml.hpp"
#include "terramrf/text_format.hpp"
#include "terramrf/yaml_keys.hpp"

namespace terramrf {
namespace fs = std::filesystem;

std::string Diagnostic::str() const {
  std::ostringstream o;
  o << file;
  if (line > 0) o << ":" << line << ":" << column;
  o << ": ";
  if (!stage.empty()) {
    o << "stage '" << stage << "'";
    if (!type.empty()) o << " (" << type << ")";
    o << ": ";
  } else if (!type.empty()) {
    o << "stage of type '" << type << "': ";
  }
  o << message;
  return o.str();
}

namespace {
std::string joinDiags(const std::vector<Diagnostic>& d) {
  std::string s;
  for (const auto& x : d) s += (s.empty() ? "" : "\n") + x.str();
  return s;
}
}  // namespace

ConfigError::ConfigError(std::vector<Diagnostic> d)
    : std::runtime_error(joinDiags(d)), diags_(std::move(d)) {}

namespace detail {

void Diags::add(const YAML::Mark& m, const std::string& msg, const std::string& stage,
                const std::string& type) {
  Diagnostic d;
  d.file = file;
  if (m.line >= 0 && m.pos >= 0) {
    d.line = m.line + 1;
    d.column = m.column + 1;
  }
  d.stage = stage;
  d.type = type;
  d.message = msg;
  // An entry shared by several places (a sweep's dataset in two split items) is checked at each:
  // say its fault once.
  for (const Diagnostic& x : list)
    if (x.line == d.line && x.column == d.column && x.file == d.file && x.stage == d.stage &&
        x.type == d.type && x.message == d.message)
      return;
  list.push_back(std::move(d));
}

void Diags::throwIfAny() const {
  if (!list.empty()) throw ConfigError(list);
}

void checkKeys(Diags& d, const YAML::Node& map, const std::vector<std::string>& allowed,
               const std::string& what, KeyHint hint, const std::string& stage,
               const std::string& type) {
  for (auto it = map.begin(); it != map.end(); ++it) {
    const std::string k = it->first.Scalar();
    if (std::find(allowed.begin(), allowed.end(), k) != allowed.end()) continue;
    std::string m = "unknown key '" + k + "' in " + what;
    const std::string dym = didYouMean(k, allowed);
    if (!dym.empty()) {
      m += " (did you mean '" + dym + "'?)";
    } else if (hint == KeyHint::kNearestOrAll) {
      m += " (expected one of: ";
      for (std::size_t i = 0; i < allowed.size(); ++i) m += (i ? ", " : "") + allowed[i];
      m += ")";
    }
    d.add(it->first.Mark(), m, stage, type);
  }
}

YAML::Node copyMapKeepingPositions(const YAML::Node& map) {
  YAML::Node out(YAML::NodeType::Map);
  if (map && map.IsMap())
    for (auto it = map.begin(); it != map.end(); ++it) out[it->first] = it->second;
  return out;
}

YAML::Node copyEntryKeepingPositions(const YAML::Node& entry) {
  YAML::Node out = copyMapKeepingPositions(entry);
  const YAML::Node given = entry.IsMap() ? entry["params"] : YAML::Node();
  if (given && !given.IsNull() && !given.IsMap()) return out;  // a diagnostic for the caller
  const YAML::Node params = copyMapKeepingPositions(given);
  out.remove("params");
  out["params"] = params;
  return out;
}

YAML::Mark valueMark(const YAML::Node& map, const std::string& key) {
  if (!map.IsMap()) return map.Mark();
  for (auto it = map.begin(); it != map.end(); ++it) {
    if (!it->first.IsScalar() || it->first.Scalar() != key) continue;
    return it->second.IsNull() ? it->first.Mark() : it->second.Mark();
  }
  return map.Mark();
}

YAML::Node unaliasedCopy(const YAML::Node& n) {
  switch (n.Type()) {
    case YAML::NodeType::Map: {
      YAML::Node out(YAML::NodeType::Map);
      for (auto it = n.begin(); it != n.end(); ++it)
        out[unaliasedCopy(it->first)] = unaliasedCopy(it->second);
      return out;
    }
    case YAML::NodeType::Sequence: {
      YAML::Node out(YAML::NodeType::Sequence);
      for (const auto& v : n) out.push_back(unaliasedCopy(v));
      return out;
    }
    case YAML::NodeType::Scalar: {
      YAML::Node out(n.Scalar());
      out.SetTag(n.Tag());
      out.SetStyle(n.Style());
      return out;
    }
    case YAML::NodeType::Null:
      return YAML::Node(YAML::NodeType::Null);
    default:
      return YAML::Node();
  }
}

void checkDuplicateKeys(const YAML::Node& n, Diags& d) {
  for (const RepeatedYamlKey& r : repeatedYamlKeys(n)) {
    YAML::Mark m;
    m.line = r.line - 1;
    m.column = r.column - 1;
    d.add(m, r.what());  // Diags puts the position in front
  }
}

YAML::Node loadYamlFile(const std::string& path, Diags& d, const std::string& what) {
  if (!fs::exists(path)) {
    d.add(YAML::Mark::null_mark(), what + " does not exist");
    d.throwIfAny();
  }
  if (fs::is_directory(path)) {
    d.add(YAML::Mark::null_mark(), what + " is a folder; expected a YAML file");
    d.throwIfAny();
  }
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    d.add(e.mark, "YAML syntax error: " + e.msg);
    d.throwIfAny();
  }
  // yaml-cpp keeps both entries of a repeated key and lookups return the first: a second
  // `icm:` or `L:` would silently be ignored, or mix its results with the first one's.
  checkDuplicateKeys(root, d);
  return root;
}

namespace {
/// The top-level keys only one kind of file has.
const std::vector<std::string> kSweepOnlyKeys = {"datasets", "feature_sets", "optimisers"};
const std::vector<std::string> kPipelineOnlyKeys = {"source", "stages"};

std::vector<std::string> presentKeys(const YAML::Node& root, const std::vector<std::string>& keys) {
  std::vector<std::string> out;
  for (const auto& k : keys)
    if (root[k]) out.push_back("'" + k + "'");
  return out;
}

}  // namespace

void requireTopLevelMap(const YAML::Node& root, Diags& d, const std::string& expected) {
  if (root.IsMap()) return;
  if (!root || root.IsNull())
    d.add(YAML::Mark::null_mark(), "the file holds nothing (empty, or comments only); " + expected);
  else
    d.add(root.Mark(), expected);
  d.throwIfAny();
}

void refuseOtherKind(const YAML::Node& root, FileKind expected, Diags& d) {
  if (!root.IsMap()) return;
  const auto sweep = presentKeys(root, kSweepOnlyKeys);
  const auto pipeline = presentKeys(root, kPipelineOnlyKeys);
  if (expected == FileKind::kPipeline && !sweep.empty() && pipeline.empty()) {
    d.add(root.Mark(), "this is a sweep (it has " + joinNames(sweep, "") +
                           "): run it with 'terramrf compare'; run, train and mesh read a "
                           "pipeline config (version, grid, source, stages, outputs)");
    d.throwIfAny();
  }
  if (expected == FileKind::kSweep && !pipeline.empty() && sweep.empty()) {
    d.add(root.Mark(), "this is a pipeline config (it has " + joinNames(pipeline, "") +
                           "): run it with 'terramrf run' or 'terramrf train'; compare reads a "
                           "sweep (version, datasets, split, feature_sets, optimisers; "
                           "docs/compare.md)");
    d.throwIfAny();
  }
}

void checkVersion(const YAML::Node& root, Diags& d) {
  if (!root["version"]) {
    d.add(root.Mark(), "missing key 'version' (expected 'version: 1')");
  } else if (root["version"].Scalar() != "1") {
    d.add(root["version"].Mark(),
          "unsupported version '" + root["version"].Scalar() + "' (this build reads version 1)");
  }
}

CommonKeys readCommonKeys(const YAML::Node& root, const std::string& base_dir,
                          PluginRegistry& reg, Diags& d, KeyHint hint) {
  CommonKeys k;
  if (const YAML::Node pp = root["plugin_path"]) {
    std::vector<std::string> found;
    if (!pp.IsSequence()) {
      d.add(pp.Mark(), "'plugin_path' must be a list of folders");
    } else {
      for (const auto& e : pp) {
        if (!e.IsScalar()) {
          d.add(e.Mark(), "plugin_path entries must be folder names");
          continue;
        }
        const std::string dir = (fs::path(base_dir) / e.Scalar()).lexically_normal().string();
        k.plugin_dirs.push_back(dir);
        // An error here, at its line; the registry would only warn of it (as of an environment
        // variable's folder), and the run would go on without the plugins meant.
        if (fs::is_directory(dir))
          found.push_back(dir);
        else
          d.add(e.Mark(), "plugin_path entry '" + dir + "' is not a folder");
      }
      if (!found.empty()) reg.prependDirs(found);
    }
  }
  if (const YAML::Node g = root["grid"]) {
    if (!g.IsMap()) {
      d.add(g.Mark(), "'grid' must be a map {size_m, cell_m}");
    } else {
      checkKeys(d, g, {"size_m", "cell_m"}, "grid", hint);
      auto num = [&](const char* key, double lo, double hi, double& out) {
        if (!g[key]) return;
        try {
          const double v = g[key].as<double>();
          if (!(v >= lo && v <= hi)) {  // also .nan, which no comparison catches otherwise
            std::ostringstream o;
            o << "grid." << key << " = " << v << " out of range: expected [" << lo << ", " << hi
              << "] m";
            d.add(g[key].Mark(), o.str());
          } else {
            out = v;
          }
        } catch (const YAML::Exception&) {
          d.add(g[key].Mark(), std::string("grid.") + key + ": expected a number in metres");
        }
      };
      num("size_m", 20, 100, k.grid.size_m);
      num("cell_m", 0.05, 5, k.grid.cell_m);
      // The grid holds a whole number of cells: 40 m of 0.3 m cells would silently cover 39.9 m.
      const double n = k.grid.size_m / k.grid.cell_m;
      if (std::fabs(n - std::round(n)) > 1e-6 * n) {
        const double below = std::floor(n) * k.grid.cell_m, above = std::ceil(n) * k.grid.cell_m;
        std::ostringstream o;
        o << "grid.size_m = " << k.grid.size_m << " is not a whole number of " << k.grid.cell_m
          << " m cells (" << n << "); expected a multiple of cell_m, e.g. " << below << " or "
          << above;
        d.add(g["size_m"] ? g["size_m"].Mark() : g.Mark(), o.str());
      }
    }
  }
  // labels (optional): list of {name, color: [r,g,b]} starting with unknown. Each fault is named
  // at its entry: yaml-cpp's own conversion messages name no place a user could find.
  if (const YAML::Node l = root["labels"]) {
    const std::size_t before = d.list.size();
    const std::string shape =
        "expected a list of {name, color: [r, g, b]}, the first named 'unknown'";
    std::vector<LabelInfo> infos;
    if (!l.IsSequence() || l.size() == 0) {
      d.add(l.Mark(), "'labels' must be a non-empty list: " + shape);
    } else if (l.size() > 255) {
      d.add(l.Mark(),
            "labels: " + std::to_string(l.size()) + " classes; at most 255 (ids are bytes)");
    } else {
      for (std::size_t i = 0; i < l.size(); ++i) {
        const YAML::Node e = l[i];
        const std::string at = "labels[" + std::to_string(i) + "]";
        if (!e.IsMap()) {
          d.add(e.Mark(), at + ": " + shape);
          continue;
        }
        checkKeys(d, e, {"name", "color"}, at, hint);
        LabelInfo li;
        const YAML::Node name = e["name"], col = e["color"];
        if (!name || !name.IsScalar() || name.Scalar().empty()) {
          d.add(name ? name.Mark() : e.Mark(), at + ": expected 'name: <class name>'");
        } else {
          li.name = name.Scalar();
          // Class names become layer names (score.<class>), CSV columns and Markdown cells; a
          // comma, bar or space would shift every column after it.
          const bool plain = std::all_of(li.name.begin(), li.name.end(), [](unsigned char ch) {
            return std::isalnum(ch) || ch == '_' || ch == '-';
          });
          if (!plain)
            d.add(name.Mark(), at + ".name: '" + li.name +
                                   "' holds characters other than letters, digits, '_' and '-'; "
                                   "class names become layer names (score.<class>) and table "
                                   "columns, e.g. 'parking_lot'");
          for (const auto& prev : infos)
            if (prev.name == li.name)
              d.add(name.Mark(), at + ": class '" + li.name + "' is listed twice");
          if (i == 0 && li.name != "unknown")
            d.add(name.Mark(),
                  at + ": the first class (id 0, no data) must be named 'unknown', got '" +
                      li.name + "'");
          if (i > 0 && li.name == "unknown")
            d.add(name.Mark(), at + ": 'unknown' must be the first class (id 0)");
        }
        bool colour_ok = col && col.IsSequence() && col.size() == 3;
        for (std::size_t c = 0; colour_ok && c < 3; ++c) {
          int v = -1;
          try {
            v = col[c].as<int>();
          } catch (const YAML::Exception&) {
          }
          if (v < 0 || v > 255) colour_ok = false;
          li.rgb[c] = static_cast<uint8_t>(v);
        }
        if (!colour_ok)
          d.add(col ? col.Mark() : e.Mark(),
                at + ".color: expected [r, g, b], three integers from 0 to 255");
        infos.push_back(li);
      }
    }
    if (d.list.size() == before) {
      k.labels = std::make_shared<LabelSet>(infos);
      k.custom_labels = true;
    }
  }
  return k;
}

const std::vector<std::string> kEntryKeys = {"name", "type", "params"};

std::string kindList(const std::vector<PluginKind>& kinds) {
  std::string s;
  for (auto k : kinds) s += (s.empty() ? "" : "/") + std::string(toString(k));
  return s;
}

namespace {
// A copied entry (a sweep's dataset in a split item) has no position of its own; its keys keep
// theirs, so the first key stands for the entry.
/// The first position held anywhere in `n` (depth first), or the null mark.
YAML::Mark firstMark(const YAML::Node& n) {
  if (n.Mark().line >= 0) return n.Mark();
  if (n.IsMap()) {
    for (auto it = n.begin(); it != n.end(); ++it) {
      if (it->first.Mark().line >= 0) return it->first.Mark();
      if (const YAML::Mark m = firstMark(it->second); m.line >= 0) return m;
    }
  } else if (n.IsSequence()) {
    for (const auto& v : n)
      if (const YAML::Mark m = firstMark(v); m.line >= 0) return m;
  }
  return YAML::Mark::null_mark();
}

/// Where an entry stands. Copies made to keep positions (copyEntryKeepingPositions) are new maps,
/// and their `params` key is new too: an entry holding only params has its position inside them.
YAML::Mark entryMark(const YAML::Node& e) { return firstMark(e); }
}  // namespace

EntryPlugin createEntryPlugin(PluginRegistry& reg, const YAML::Node& e, const std::string& section,
                              const std::vector<PluginKind>& kinds, Diags& d,
                              const EntryChecks& checks) {
  EntryPlugin ep;
  if (!e.IsMap()) {
    d.add(e.Mark(), section + " entries must be maps {name, type, params}");
    return ep;
  }
  // Scalar() of a list or a null is "": such a name or type would pass for an empty one.
  const YAML::Node type_node = e["type"], name_node = e["name"];
  if (type_node && (type_node.IsSequence() || type_node.IsMap())) {  // a null is "empty" below
    d.add(type_node.Mark(), "'type' must be a plugin type name, got " + describeNode(type_node));
    return ep;
  }
  ep.type = type_node ? type_node.Scalar() : "";
  if (name_node) {
    // Stage names head timing rows, metric keys (<name>.<metric>) and table cells.
    const std::string n = name_node.IsScalar() ? name_node.Scalar() : "";
    const bool plain = !n.empty() && std::all_of(n.begin(), n.end(), [](unsigned char ch) {
      return std::isalnum(ch) || ch == '_' || ch == '-' || ch == '.';
    });
    if (!plain) {
      d.add(valueMark(e, "name"),
            "'name' must be a non-empty name of letters, digits, '_', '-' and '.' (it heads the "
            "timing table's rows and the metric keys), got " +
                describeNode(name_node),
            "", ep.type);
      return ep;
    }
  }
  ep.name = name_node ? name_node.Scalar() : ep.type;
  if (checks.key_errors_name_the_stage) {
    checkKeys(d, e, kEntryKeys, section + " entry", checks.key_hint,
              e["name"] ? e["name"].Scalar() : "", ep.type);
  } else {
    checkKeys(d, e, kEntryKeys, section + " entry", checks.key_hint);
  }
  const std::string& name = ep.name;
  const std::string& type = ep.type;
  if (type.empty()) {
    const YAML::Mark at = e["type"] && e["type"].Mark().line >= 0 ? e["type"].Mark() : entryMark(e);
    d.add(at,
          e["type"] ? "'type' is empty; expected the plugin type name"
                    : "missing key 'type' (the plugin type name)",
          name);
    return ep;
  }
  if (checks.unique_names && !checks.unique_names->insert(name).second)
    d.add(e["name"] ? e["name"].Mark() : e.Mark(),
          "duplicate stage name '" + name + "' (give each a unique name:)", name, type);
  // The runner times its own steps under these names (timing.md, compare's runtime table).
  const bool stage_entry = std::none_of(kinds.begin(), kinds.end(), [](PluginKind k) {
    return k == PluginKind::kSource || k == PluginKind::kOutput;
  });
  if (stage_entry && (name == "read" || name == "read wait" || name == "grid" || name == "total"))
    d.add(e["name"] ? e["name"].Mark() : e.Mark(),
          "stage name '" + name +
              "' is the runner's own (read, read wait, grid, total in the "
              "timing table); give the stage another name:",
          name, type);
  const PluginInfo* info = reg.find(type);
  if (!info) {
    ep.unknown_type = true;
    ep.suggestion = didYouMean(type, reg.types());
    return ep;
  }
  if (std::find(kinds.begin(), kinds.end(), info->kind) == kinds.end()) {
    d.add(e["type"].Mark(),
          "'" + type + "' is a " + toString(info->kind) + " plugin, but " + section + " takes " +
              kindList(kinds) + " plugins",
          name, type);
    return ep;
  }
  ep.kind = info->kind;
  std::unique_ptr<Plugin> plugin;
  try {
    plugin = reg.create(type);
  } catch (const std::exception& ex) {
    d.add(e["type"].Mark(), ex.what(), name, type);
    return ep;
  }
  plugin->setIdentity(name, type);
  ep.plugin = std::move(plugin);
  return ep;
}

bool applyEntryParams(Plugin& plugin, const YAML::Node& e, const PluginContext& ctx, Diags& d,
                      const std::vector<std::pair<std::string, std::string>>& overrides) {
  const YAML::Mark at = entryMark(e);
  const auto issues = applyParams(plugin, e["params"], ctx, at, overrides);
  for (const auto& i : issues)
    d.add(i.mark.line >= 0 ? i.mark : at, i.message, plugin.name(), plugin.type());
  return issues.empty();
}

void recordLayerOrigins(Plugin& stage, double cell_m, std::map<std::string, std::string>& origins) {
  YAML::Node n(YAML::NodeType::Map);
  n["stage"] = stage.type();
  n["cell_m"] = cell_m;  // per-cell features change with the cell size
  n["params"] = currentParams(stage);
  for (const auto& r : stage.reads())
    if (const auto it = origins.find(r); it != origins.end())
      n["inputs"][r] = YAML::Load(it->second);
  YAML::Emitter em;
  em << YAML::Flow << n;
  for (const auto& w : stage.writes())
    if (!w.empty() && w[0] != '@') origins[w] = em.c_str();
}

void recordSourceOrigins(const Source& s, std::map<std::string, std::string>& origins) {
  const std::vector<std::string> declared = s.writes();
  for (const auto& [layer, origin] : s.layerOrigins())
    if (!layer.empty() && layer[0] != '@' &&
        std::find(declared.begin(), declared.end(), layer) != declared.end())
      origins[layer] = origin;
}

}  // namespace detail

bool isSweepFile(const std::string& path) {
  if (!fs::is_regular_file(path)) return false;  // the loader says what it is
  try {
    const YAML::Node root = YAML::LoadFile(path);
    return root.IsMap() && !detail::presentKeys(root, detail::kSweepOnlyKeys).empty() &&
           detail::presentKeys(root, detail::kPipelineOnlyKeys).empty();
  } catch (const YAML::Exception&) {
    return false;  // the pipeline loader reports it with its position
  }
}

const std::vector<std::string> detail::kPipelineKeys = {
    "version", "plugin_path", "grid", "labels", "split", "source", "stages", "outputs", "output_dir"};

Pipeline loadPipeline(const std::string& config_path, const LoadOptions& options,
                      PluginRegistry& registry) {
  detail::Diags c;
  c.file = config_path;
  const YAML::Node root = detail::loadYamlFile(config_path, c, "config file");
  detail::requireTopLevelMap(root, c,
                             "expected a map with keys version, grid, source, stages, outputs");
  detail::refuseOtherKind(root, detail::FileKind::kPipeline, c);
  detail::checkKeys(c, root, detail::kPipelineKeys, "the config");

  Pipeline p;
  p.config_path = config_path;
  const std::string config_dir = fs::absolute(config_path).parent_path().string();

  detail::checkVersion(root, c);
  detail::CommonKeys common = detail::readCommonKeys(root, config_dir, registry, c);
  p.grid = common.grid;
  p.labels = common.labels;

  // output dir
  p.output_dir = options.output_dir;
  const YAML::Node od = root["output_dir"];
  // A list, a null or "" would read as "" and put every output next to the config.
  const bool od_ok = !od || (od.IsScalar() && !od.Scalar().empty());
  if (!od_ok)
    c.add(
        detail::valueMark(root, "output_dir"),
        "'output_dir' must be a folder name (a non-empty string), got " + detail::describeNode(od));
  if (p.output_dir.empty()) {
    p.output_dir = od && od_ok ? (fs::path(config_dir) / od.Scalar()).string()
                               : (fs::current_path() / "out").string();
  }
  p.output_dir = fs::absolute(p.output_dir).lexically_normal().string();

  PluginContext ctx;
  ctx.config_dir = config_dir;
  ctx.output_dir = p.output_dir;
  ctx.grid = p.grid;
  ctx.labels = p.labels.get();
  // Grows as the stages are made: each sees how the layers before it are computed.
  ctx.layer_origins = &p.layer_origins;

  // Unaliased: stages that share their params through a YAML alias get one resolved copy each.
  YAML::Node resolved = detail::unaliasedCopy(root);
  // Folders as this run found them: relative ones would be read against the output folder, where
  // the resolved config is written.
  if (root["plugin_path"] && root["plugin_path"].IsSequence()) {
    YAML::Node dirs(YAML::NodeType::Sequence);
    for (const auto& dir : common.plugin_dirs) dirs.push_back(fs::absolute(dir).string());
    resolved["plugin_path"] = dirs;
  }
  if (od) resolved["output_dir"] = p.output_dir;
  // A `grid:` that is not a map is already a diagnostic; indexing into it would throw yaml-cpp's
  // own error instead of the list of problems.
  if (!resolved["grid"].IsMap()) resolved["grid"] = YAML::Node(YAML::NodeType::Map);
  resolved["grid"]["size_m"] = p.grid.size_m;
  resolved["grid"]["cell_m"] = p.grid.cell_m;

  // Instantiates one plugin entry; returns nullptr after recording diagnostics.
  std::set<std::string> names;
  auto make = [&](const YAML::Node& e, const std::string& section,
                  const std::vector<PluginKind>& kinds, PluginKind* kind_out,
                  const std::vector<std::pair<std::string, std::string>>& overrides,
                  YAML::Node resolved_entry) -> std::unique_ptr<Plugin> {
    detail::EntryChecks checks;
    checks.unique_names = &names;
    detail::EntryPlugin ep = detail::createEntryPlugin(registry, e, section, kinds, c, checks);
    if (ep.unknown_type) {
      std::string m = "unknown plugin type '" + ep.type + "'";
      if (!ep.suggestion.empty()) m += " (did you mean '" + ep.suggestion + "'?)";
      m += "; run 'terramrf plugins' for the list";
      c.add(e["type"].Mark(), m, ep.name, ep.type);
      return nullptr;
    }
    if (!ep.plugin) return nullptr;
    if (kind_out) *kind_out = ep.kind;
    if (!detail::applyEntryParams(*ep.plugin, e, ctx, c, overrides)) return nullptr;
    resolved_entry["name"] = ep.name;
    resolved_entry["params"] = detail::currentParams(*ep.plugin);
    return std::move(ep.plugin);
  };

  // source
  if (!root["source"]) {
    c.add(root.Mark(), "missing key 'source' (where frames come from, e.g. {type: simulator})");
  } else {
    std::vector<std::pair<std::string, std::string>> ov;
    if (!options.data_override.empty())
      ov.push_back({"path", fs::absolute(options.data_override).lexically_normal().string()});
    auto pl = make(root["source"], "source", {PluginKind::kSource}, nullptr, ov, resolved["source"]);
    if (pl) p.source.reset(static_cast<Source*>(pl.release()));
  }

  // stages + the order and read/write check
  detail::StageFlow flow(c);
  if (p.source) {
    flow.source(*p.source, root["source"].Mark());
    detail::recordSourceOrigins(*p.source, p.layer_origins);
  }
  // A source that failed may have been the one to bring layers made elsewhere (Frame::grid).
  else if (root["source"])
    flow.sourceFailed();
  if (const auto st = root["stages"]) {
    if (!st.IsSequence()) {
      c.add(detail::valueMark(root, "stages"), "'stages' must be a list");
    } else {
      for (std::size_t i = 0; i < st.size(); ++i) {
        PluginKind kind = PluginKind::kFeature;
        auto pl = make(st[i], "stages",
                       {PluginKind::kEgomotion, PluginKind::kFeature, PluginKind::kEnergy,
                        PluginKind::kOptimiser},
                       &kind, {}, resolved["stages"][i]);
        if (!pl) {
          flow.entryFailed();
          continue;
        }
        flow.stage(*pl, kind, st[i].Mark());
        detail::recordLayerOrigins(*pl, p.grid.cell_m, p.layer_origins);
        p.stage_kinds.push_back(kind);
        p.stages.emplace_back(static_cast<Stage*>(pl.release()));
      }
    }
  } else {
    c.add(root.Mark(), "missing key 'stages' (features, energy, optimiser)");
  }

  if (const auto out = root["outputs"]) {
    if (!out.IsSequence()) {
      c.add(detail::valueMark(root, "outputs"), "'outputs' must be a list");
    } else {
      for (std::size_t i = 0; i < out.size(); ++i) {
        auto pl = make(out[i], "outputs", {PluginKind::kOutput}, nullptr, {}, resolved["outputs"][i]);
        if (!pl) continue;
        flow.output(*pl, out[i].Mark());
        p.outputs.emplace_back(static_cast<Output*>(pl.release()));
      }
    }
  }

  c.throwIfAny();
  YAML::Emitter em;
  em << resolved;
  p.resolved_yaml = std::string("# Resolved config: every parameter with its value (defaults filled "
                                "in) from ") + config_path + "\n" + em.c_str() + "\n";
  return p;
}

}  // namespace terramrf
