// `terramrf train` and `terramrf compare` as a library. Pipelines are assembled from YAML
// snippets of the train config / sweep file (so errors point at that file) instead of going
// through loadPipeline: a sweep combines pieces from several places, and training must not
// configure energy/optimiser stages whose model file does not exist yet.
//
// yaml-cpp: assigning one Node variable to another that already refers to a node overwrites the
// shared node (every handle sees it); rebinding a variable is Node::reset.
#include "terramrf/sweep.hpp"

#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <memory>
#include <numeric>
#include <set>
#include <sstream>

#include "param_yaml.hpp"
#include "terramrf/atomic_file.hpp"
#include "terramrf/param_values.hpp"
#include "terramrf/pipeline.hpp"
#include "terramrf/registry.hpp"
#include "terramrf/version.hpp"

namespace terramrf {
namespace fs = std::filesystem;

std::string FrameRange::str() const {
  if (all()) return "all frames";
  if (first == last) return "frame " + std::to_string(first);
  if (last == npos) return "frames " + std::to_string(first) + "-end";
  return "frames " + std::to_string(first) + "-" + std::to_string(last);
}

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// ---- diagnostics --------------------------------------------------------------------------------

struct Diags {
  std::string file;
  std::vector<Diagnostic> list;
  void add(const YAML::Mark& m, const std::string& msg, const std::string& stage = "",
           const std::string& type = "") {
    Diagnostic d;
    d.file = file;
    if (m.line >= 0 && m.pos >= 0) {
      d.line = m.line + 1;
      d.column = m.column + 1;
    }
    d.stage = stage;
    d.type = type;
    d.message = msg;
    list.push_back(std::move(d));
  }
  void throwIfAny() const {
    if (!list.empty()) throw ConfigError(list);
  }
};

void checkKeys(Diags& d, const YAML::Node& map, const std::vector<std::string>& allowed,
               const std::string& what) {
  for (auto it = map.begin(); it != map.end(); ++it) {
    const std::string k = it->first.Scalar();
    if (std::find(allowed.begin(), allowed.end(), k) != allowed.end()) continue;
    std::string m = "unknown key '" + k + "' in " + what;
    const std::string dym = detail::didYouMean(k, allowed);
    if (!dym.empty()) {
      m += " (did you mean '" + dym + "'?)";
    } else {
      m += " (expected one of: ";
      for (std::size_t i = 0; i < allowed.size(); ++i) m += (i ? ", " : "") + allowed[i];
      m += ")";
    }
    d.add(it->first.Mark(), m);
  }
}

YAML::Node loadYamlFile(const std::string& path, Diags& d) {
  if (!fs::exists(path)) {
    d.add(YAML::Mark::null_mark(), "file does not exist");
    d.throwIfAny();
  }
  try {
    return YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    d.add(e.mark, "YAML syntax error: " + e.msg);
    d.throwIfAny();
  }
  return {};
}

std::string absPath(const std::string& base_dir, const std::string& p) {
  fs::path q(p);
  if (!q.is_absolute()) q = fs::path(base_dir) / q;
  return q.lexically_normal().string();
}

std::string canonicalPath(const std::string& p) {
  std::error_code ec;
  fs::path c = fs::weakly_canonical(p, ec);
  if (ec) c = fs::path(p).lexically_normal();
  std::string s = c.string();
  while (s.size() > 1 && s.back() == '/') s.pop_back();
  return s;
}

/// True if `inner` is `outer` or lies inside it.
bool pathWithin(const std::string& inner, const std::string& outer) {
  if (inner == outer) return true;
  return inner.size() > outer.size() && inner.compare(0, outer.size(), outer) == 0 &&
         inner[outer.size()] == '/';
}

std::string sanitize(const std::string& s) {
  std::string o;
  for (char ch : s)
    o += (std::isalnum(static_cast<unsigned char>(ch)) || ch == '+' || ch == '-' || ch == '.' ||
          ch == '_')
             ? ch
             : '_';
  return o.empty() ? "_" : o;
}

std::string utcNow() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char b[32];
  std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return b;
}

std::string fmt(const char* f, double v) {
  if (std::isnan(v)) return "–";
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}
std::string csvNum(double v) {
  if (!std::isfinite(v)) return "";
  char b[48];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}
std::string jsonNum(double v) {
  if (!std::isfinite(v)) return "null";
  char b[48];
  std::snprintf(b, sizeof b, "%.9g", v);
  return b;
}
std::string jsonStr(const std::string& s) {
  std::string o = "\"";
  for (char ch : s) {
    if (ch == '"' || ch == '\\') {
      o += '\\';
      o += ch;
    } else if (ch == '\n') {
      o += "\\n";
    } else if (static_cast<unsigned char>(ch) < 0x20) {
      char b[8];
      std::snprintf(b, sizeof b, "\\u%04x", ch);
      o += b;
    } else {
      o += ch;
    }
  }
  return o + "\"";
}
std::string csvStr(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string o = "\"";
  for (char ch : s) o += ch == '"' ? std::string("\"\"") : std::string(1, ch);
  return o + "\"";
}
std::string capitalise(std::string s) {
  if (!s.empty()) s[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(s[0])));
  return s;
}

struct Stats {
  double mean = kNaN, stddev = kNaN, min = kNaN, max = kNaN, median = kNaN;
  std::size_t n = 0;
};
Stats stats(const std::vector<double>& v) {
  StageTiming t;
  t.ms = v;
  Stats s;
  s.n = v.size();
  if (v.empty()) return s;
  s.mean = t.mean();
  s.stddev = t.stddev();
  s.min = t.min();
  s.max = t.max();
  s.median = t.median();
  return s;
}

// ---- progress bar -------------------------------------------------------------------------------

class Progress {
 public:
  explicit Progress(bool enabled) : enabled_(enabled), tty_(::isatty(2) != 0) {}
  void setTotal(std::size_t n) { total_ = n; }
  void tick(const std::string& what) { advanceTo(done_ + 1, what); }
  void advanceTo(std::size_t done, const std::string& what) {
    done_ = std::min(std::max(done, done_), std::max(total_, done));
    if (!enabled_ || total_ == 0) return;
    const std::size_t step = std::max<std::size_t>(1, total_ / 20);
    if (!tty_ && (done_ == printed_ || (done_ != total_ && done_ / step == printed_ / step)))
      return;
    printed_ = done_;
    const int width = 30;
    const int filled = static_cast<int>(width * std::min(done_, total_) / total_);
    std::fprintf(stderr, "%s[%s%s] %zu/%zu scans  %s%s", tty_ ? "\r" : "",
                 std::string(filled, '#').c_str(), std::string(width - filled, '.').c_str(), done_,
                 total_, what.c_str(), tty_ ? "\033[K" : "\n");
    std::fflush(stderr);
  }
  /// Ends the bar's line so log messages start on a fresh one.
  void breakLine() {
    if (enabled_ && tty_ && total_ > 0) std::fprintf(stderr, "\n");
  }
  void finish() {
    if (enabled_ && tty_ && total_ > 0) std::fprintf(stderr, "\n");
  }

 private:
  bool enabled_, tty_;
  std::size_t total_ = 0, done_ = 0, printed_ = 0;
};

// ---- plugins from snippets ----------------------------------------------------------------------

const std::vector<std::string> kEntryKeys = {"name", "type", "params"};

std::string kindList(const std::vector<PluginKind>& ks) {
  std::string s;
  for (auto k : ks) s += (s.empty() ? "" : "/") + std::string(toString(k));
  return s;
}

/// Outcome of instantiating one `{name, type, params}` entry.
struct Made {
  std::unique_ptr<Plugin> plugin;
  std::string not_installed;  ///< set when the type is unknown and the caller tolerates that
  PluginKind kind = PluginKind::kFeature;
  bool ok() const { return plugin != nullptr; }
};

/// Creates, parameterises and configures the plugin of entry `e`. Problems become diagnostics at
/// the entry's position in `d.file`; an unknown type only sets `not_installed` when
/// `tolerate_missing`. With `configure` false only the parameter names are checked (the energy
/// entry of a sweep, whose model is trained later).
Made makePlugin(PluginRegistry& reg, const YAML::Node& e, const std::string& section,
                const std::vector<PluginKind>& kinds, const PluginContext& ctx, Diags& d,
                bool tolerate_missing, bool configure = true) {
  Made m;
  if (!e.IsMap()) {
    d.add(e.Mark(), section + " entries must be maps {name, type, params}");
    return m;
  }
  const std::string type = e["type"] ? e["type"].Scalar() : "";
  const std::string name = e["name"] ? e["name"].Scalar() : type;
  checkKeys(d, e, kEntryKeys, section + " entry");
  if (type.empty()) {
    d.add(e.Mark(), "missing key 'type' (the plugin type name)", name);
    return m;
  }
  const PluginInfo* info = reg.find(type);
  if (!info) {
    std::string why = "plugin type '" + type + "' is not installed";
    const std::string dym = detail::didYouMean(type, reg.types());
    if (!dym.empty()) why += " (did you mean '" + dym + "'?)";
    if (tolerate_missing) {
      m.not_installed = why;
    } else {
      d.add(e["type"].Mark(), why + "; run 'terramrf plugins' for the list", name, type);
    }
    return m;
  }
  if (std::find(kinds.begin(), kinds.end(), info->kind) == kinds.end()) {
    d.add(e["type"].Mark(),
          "'" + type + "' is a " + toString(info->kind) + " plugin, but " + section + " takes " +
              kindList(kinds) + " plugins",
          name, type);
    return m;
  }
  m.kind = info->kind;
  std::unique_ptr<Plugin> p;
  try {
    p = reg.create(type);
  } catch (const std::exception& ex) {
    d.add(e["type"].Mark(), ex.what(), name, type);
    return m;
  }
  p->setIdentity(name, type);
  const YAML::Node params = e["params"];
  if (!configure) {
    const auto specs = declaredParams(*p);
    std::vector<std::string> names;
    for (const auto& s : specs) names.push_back(s.name);
    if (params && params.IsMap()) {
      for (auto it = params.begin(); it != params.end(); ++it) {
        const std::string k = it->first.Scalar();
        if (std::find(names.begin(), names.end(), k) != names.end()) continue;
        std::string msg = "unknown parameter '" + k + "'";
        const std::string dym = detail::didYouMean(k, names);
        if (!dym.empty()) msg += " (did you mean '" + dym + "'?)";
        d.add(it->first.Mark(), msg, name, type);
      }
    } else if (params && !params.IsNull()) {
      d.add(params.Mark(), "'params' must be a map of parameter: value", name, type);
    }
    m.plugin = std::move(p);
    return m;
  }
  const auto issues = detail::applyParams(*p, params, ctx, e.Mark());
  for (const auto& i : issues) d.add(i.mark.line >= 0 ? i.mark : e.Mark(), i.message, name, type);
  if (issues.empty()) m.plugin = std::move(p);
  return m;
}

/// The YAML of a configured plugin as a config entry, every parameter with its value.
YAML::Node resolvedEntry(Plugin& p) {
  YAML::Node n(YAML::NodeType::Map);
  n["name"] = p.name();
  n["type"] = p.type();
  n["params"] = detail::currentParams(p);
  return n;
}

std::string paramString(Plugin& p, const std::string& key) {
  ParamDecl d;
  p.declare(d);
  const ParamSpec* s = d.find(key);
  if (!s) return "";
  const ParamValue v = s->get();
  if (const auto* str = std::get_if<std::string>(&v)) return *str;
  return toYaml(v);
}

bool hasParam(Plugin& p, const std::string& key) {
  ParamDecl d;
  p.declare(d);
  return d.find(key) != nullptr;
}

// ---- the common part of every pipeline ----------------------------------------------------------

/// What a train config or sweep file says about every pipeline it makes: grid, labels, plugin
/// folders, where relative paths start.
struct Frame0 {
  std::string file;      ///< the train config / sweep file (diagnostics)
  std::string base_dir;  ///< its folder
  GridGeometry grid;
  std::shared_ptr<LabelSet> labels = std::make_shared<LabelSet>(LabelSet::defaults());
  bool custom_labels = false;
  YAML::Node labels_node;
  std::vector<std::string> plugin_dirs;  ///< absolute, from the file's plugin_path

  PluginContext context(const std::string& output_dir) const {
    PluginContext ctx;
    ctx.config_dir = base_dir;
    ctx.output_dir = output_dir;
    ctx.grid = grid;
    ctx.labels = labels.get();
    return ctx;
  }
};

/// Reads grid, labels and plugin_path like loadPipeline does.
void readFrame0(const YAML::Node& root, Frame0& f0, Diags& d, PluginRegistry& reg) {
  if (const YAML::Node pp = root["plugin_path"]) {
    if (!pp.IsSequence()) {
      d.add(pp.Mark(), "'plugin_path' must be a list of folders");
    } else {
      for (const auto& e : pp) {
        const std::string dir = absPath(f0.base_dir, e.Scalar());
        if (!fs::is_directory(dir))
          d.add(e.Mark(), "plugin_path entry '" + dir + "' is not a folder");
        f0.plugin_dirs.push_back(dir);
      }
      if (!f0.plugin_dirs.empty()) reg.prependDirs(f0.plugin_dirs);
    }
  }
  if (const YAML::Node g = root["grid"]) {
    if (!g.IsMap()) {
      d.add(g.Mark(), "'grid' must be a map {size_m, cell_m}");
    } else {
      checkKeys(d, g, {"size_m", "cell_m"}, "grid");
      auto num = [&](const char* key, double lo, double hi, double& out) {
        if (!g[key]) return;
        try {
          const double v = g[key].as<double>();
          if (v < lo || v > hi) {
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
      num("size_m", 20, 100, f0.grid.size_m);
      num("cell_m", 0.05, 5, f0.grid.cell_m);
    }
  }
  if (const YAML::Node l = root["labels"]) {
    try {
      std::vector<LabelInfo> infos;
      for (const auto& e : l) {
        LabelInfo li;
        li.name = e["name"].as<std::string>();
        const auto col = e["color"].as<std::vector<int>>();
        if (col.size() != 3) throw std::runtime_error("color must be [r, g, b]");
        for (int k = 0; k < 3; ++k) li.rgb[k] = static_cast<uint8_t>(col[k]);
        infos.push_back(li);
      }
      f0.labels = std::make_shared<LabelSet>(infos);
      f0.custom_labels = true;
      f0.labels_node = l;
    } catch (const std::exception& e) {
      d.add(l.Mark(), std::string("labels: expected a list of {name, color: [r, g, b]} starting "
                                  "with 'unknown': ") +
                          e.what());
    }
  }
}

// ---- split items ------------------------------------------------------------------------------

/// One element of a split: a source entry (with the item's overrides applied) and frames.
struct Item {
  std::string dataset;  ///< sweep dataset name ("" in train configs)
  std::string label;    ///< unique display name
  YAML::Node source;    ///< {name, type, params} after overrides
  std::string type;
  FrameRange frames;
  YAML::Mark mark;
  bool range_given = false;
  // Identity of the data, for the overlap check.
  std::string path;      ///< canonical data folder, if the source reads one
  std::string identity;  ///< type + distinguishing parameters, when there is no path
  std::string identity_text;
  // Filled when prepared.
  std::unique_ptr<Source> src;
  std::string unavailable;           ///< why the source cannot be made (type not installed)
  std::size_t size = 0;              ///< frames of the source
  std::size_t first = 0, count = 0;  ///< frames to run after range and limit
};

/// Parses `frames: [first, last]` (inclusive) or `frames: N` (one frame).
bool parseFrames(const YAML::Node& n, FrameRange& r, Diags& d) {
  auto idx = [&](const YAML::Node& x, std::size_t& out) {
    try {
      const long long v = x.as<long long>();
      if (v < 0) throw YAML::Exception(x.Mark(), "negative");
      out = static_cast<std::size_t>(v);
      return true;
    } catch (const YAML::Exception&) {
      d.add(x.Mark(), "frames: expected a frame index >= 0, got '" + x.Scalar() + "'");
      return false;
    }
  };
  if (n.IsScalar()) {
    if (!idx(n, r.first)) return false;
    r.last = r.first;
    return true;
  }
  if (!n.IsSequence() || n.size() != 2) {
    d.add(n.Mark(), "frames: expected [first, last] (inclusive frame indices) or one index");
    return false;
  }
  if (!idx(n[0], r.first) || !idx(n[1], r.last)) return false;
  if (r.last < r.first) {
    d.add(n.Mark(), "frames: last (" + std::to_string(r.last) + ") is before first (" +
                        std::to_string(r.first) + ")");
    return false;
  }
  return true;
}

/// Fills the item's data identity: the canonical `path` if the source has one; else the type and
/// its `seed` if it has one; else the type with every parameter except `frames` (a count, not a
/// selection). Defaults are filled in when the plugin is installed, so `seed: 1` and an omitted
/// default seed compare equal.
void identify(Item& it, const std::string& base_dir, PluginRegistry& reg) {
  const YAML::Node params = it.source["params"];
  if (params && params.IsMap() && params["path"] && params["path"].IsScalar()) {
    it.path = canonicalPath(absPath(base_dir, params["path"].Scalar()));
    it.identity_text = it.path;
    return;
  }
  std::map<std::string, std::string> kv;
  if (const PluginInfo* info = reg.find(it.type)) {
    (void)info;
    try {
      auto p = reg.create(it.type);
      for (const auto& s : declaredParams(*p)) kv[s.name] = toYaml(s.default_value);
    } catch (const std::exception&) {
    }
  }
  if (params && params.IsMap()) {
    for (auto p = params.begin(); p != params.end(); ++p) {
      YAML::Emitter em;
      em << YAML::Flow << p->second;
      kv[p->first.Scalar()] = em.c_str();
    }
  }
  kv.erase("frames");
  if (kv.count("seed")) {
    // A seed names a generated world: the same seed with other parameters (noise, speed) is
    // still the same terrain and objects, so it must not be on both sides of a split.
    kv = {{"seed", kv["seed"]}};
  }
  it.identity = it.type + "{";
  for (const auto& [k, v] : kv) it.identity += k + ":" + v + ";";
  it.identity += "}";
  it.identity_text = it.type;
  if (kv.count("seed")) it.identity_text += " seed " + kv["seed"];
}

/// Parses one split item. `datasets` (sweeps) maps names to source entries; `base_source`
/// (train configs) is the config's source. A scalar is a dataset name (sweep) or a data folder
/// (train config); a map has keys dataset, path, params, frames.
bool parseItem(const YAML::Node& n, const std::map<std::string, YAML::Node>* datasets,
               const YAML::Node& base_source, const std::string& base_dir, Diags& d, Item& it) {
  it.mark = n.Mark();
  YAML::Node base = base_source;
  std::string path_override;
  YAML::Node params_override;
  if (n.IsScalar()) {
    if (datasets) {
      it.dataset = n.Scalar();
    } else {
      path_override = n.Scalar();
    }
  } else if (n.IsMap()) {
    std::vector<std::string> keys = {"path", "params", "frames"};
    if (datasets) keys.insert(keys.begin(), "dataset");
    checkKeys(d, n, keys, "split item");
    if (datasets && n["dataset"]) it.dataset = n["dataset"].Scalar();
    if (n["path"]) path_override = n["path"].Scalar();
    if (n["params"]) {
      params_override = n["params"];
      if (!params_override.IsMap()) {
        d.add(params_override.Mark(), "split item 'params' must be a map of source parameters");
        return false;
      }
    }
    if (n["frames"]) {
      if (!parseFrames(n["frames"], it.frames, d)) return false;
      it.range_given = true;
    }
  } else {
    d.add(n.Mark(), datasets ? "split item: expected a dataset name or {dataset, frames, params}"
                             : "split item: expected a data folder or {path, frames, params}");
    return false;
  }
  if (datasets) {
    if (it.dataset.empty()) {
      d.add(n.Mark(), "split item needs 'dataset: <name>' (one of the datasets section)");
      return false;
    }
    auto f = datasets->find(it.dataset);
    if (f == datasets->end()) {
      std::vector<std::string> names;
      for (const auto& [k, v] : *datasets) names.push_back(k);
      std::string m = "unknown dataset '" + it.dataset + "'";
      const std::string dym = detail::didYouMean(it.dataset, names);
      if (!dym.empty()) m += " (did you mean '" + dym + "'?)";
      d.add(n.Mark(), m);
      return false;
    }
    base.reset(f->second);  // reset: operator= would overwrite the shared node
  }
  if (!base || !base.IsMap()) return false;
  it.source = YAML::Clone(base);
  if (!it.source["params"] || it.source["params"].IsNull())
    it.source["params"] = YAML::Node(YAML::NodeType::Map);
  if (params_override)
    for (auto p = params_override.begin(); p != params_override.end(); ++p)
      it.source["params"][p->first.Scalar()] = p->second;
  if (!path_override.empty()) {
    const std::string abs = absPath(base_dir, path_override);
    if (!fs::exists(abs)) {
      d.add(n.Mark(), "data folder '" + abs + "' does not exist");
      return false;
    }
    it.source["params"]["path"] = abs;
  }
  it.type = it.source["type"] ? it.source["type"].Scalar() : "";
  // Display name.
  if (!it.dataset.empty()) {
    it.label = it.dataset;
  } else if (!path_override.empty()) {
    it.label = fs::path(path_override).lexically_normal().string();
  } else {
    it.label = it.type;
    if (params_override)
      for (auto p = params_override.begin(); p != params_override.end(); ++p)
        it.label +=
            " " + p->first.Scalar() + "=" + (p->second.IsScalar() ? p->second.Scalar() : "…");
  }
  return true;
}

std::string itemText(const Item& it) {
  return "'" + it.label + "' (" + it.frames.str() + " of " + it.identity_text + ")";
}

/// Train and test items must not share data: same folder (or one inside the other) or same
/// parameters without a path, with intersecting frame ranges. Diagnostics at the test item.
void checkDisjoint(const std::vector<Item*>& train, const std::vector<Item*>& test, Diags& d) {
  for (const Item* t : test) {
    for (const Item* r : train) {
      std::string why;
      if (!t->path.empty() && !r->path.empty()) {
        if (t->path == r->path) {
          if (t->frames.overlaps(r->frames)) {
            const std::size_t a = std::max(t->frames.first, r->frames.first);
            const std::size_t b = std::min(t->frames.last, r->frames.last);
            why = "both read " + t->path + ", " + FrameRange{a, b}.str() + " in both";
          }
        } else if (pathWithin(t->path, r->path) || pathWithin(r->path, t->path)) {
          why = "one data folder contains the other (" + r->path + " / " + t->path + ")";
        }
      } else if (t->path.empty() && r->path.empty() && t->identity == r->identity &&
                 t->frames.overlaps(r->frames)) {
        const std::size_t a = std::max(t->frames.first, r->frames.first);
        const std::size_t b = std::min(t->frames.last, r->frames.last);
        why = "same source and parameters (" + t->identity_text + "), " + FrameRange{a, b}.str() +
              " in both";
      }
      if (why.empty()) continue;
      std::string where;
      if (r->mark.line >= 0) where = " at line " + std::to_string(r->mark.line + 1);
      d.add(t->mark, "split: test item " + itemText(*t) + " overlaps train item " + itemText(*r) +
                         where + ": " + why + "; train and test sets must be disjoint");
    }
  }
}

/// Instantiates and configures the item's source (unless its type is not installed); checks
/// the frame range against the source's size and applies `limit`.
void prepareItem(Item& it, PluginRegistry& reg, const Frame0& f0, const std::string& out_dir,
                 std::size_t limit, Diags& d, bool tolerate_missing) {
  Made m = makePlugin(reg, it.source, "source", {PluginKind::kSource}, f0.context(out_dir), d,
                      tolerate_missing);
  if (!m.ok()) {
    it.unavailable = m.not_installed;
    return;
  }
  it.src.reset(static_cast<Source*>(m.plugin.release()));
  it.size = it.src->size();
  if (it.frames.first >= it.size) {
    d.add(it.mark, "split item '" + it.label + "' asks for " + it.frames.str() +
                       " but the source has " + std::to_string(it.size) + " frame(s)");
    it.src.reset();
    return;
  }
  const std::size_t last = std::min(it.frames.last, it.size - 1);
  it.first = it.frames.first;
  it.count = last - it.first + 1;
  if (limit > 0) it.count = std::min(it.count, limit);
}

/// Gives an item's configured source to a pipeline for one run and takes it back afterwards,
/// also when the run throws.
class SourceLoan {
 public:
  SourceLoan(Item& it, Pipeline& p) : it_(it), p_(p) { p_.source = std::move(it_.src); }
  ~SourceLoan() { it_.src = std::move(p_.source); }

 private:
  Item& it_;
  Pipeline& p_;
};

// ---- pipelines ----------------------------------------------------------------------------------

/// Assembles a Pipeline from entries (already validated against `d.file`); the source is lent by
/// the caller. Re-checks the read/write order like loadPipeline; throws ConfigError.
Pipeline assemble(PluginRegistry& reg, const Frame0& f0, Item& item,
                  const std::vector<YAML::Node>& stage_entries,
                  const std::vector<YAML::Node>& output_entries,
                  std::vector<std::unique_ptr<Output>> extra_outputs, const std::string& run_dir) {
  Diags d;
  d.file = f0.file;
  Pipeline p;
  p.config_path = f0.file;
  p.output_dir = fs::absolute(run_dir).lexically_normal().string();
  p.grid = f0.grid;
  p.labels = f0.labels;
  const PluginContext ctx = f0.context(p.output_dir);
  YAML::Node resolved(YAML::NodeType::Map);
  resolved["version"] = 1;
  resolved["grid"]["size_m"] = f0.grid.size_m;
  resolved["grid"]["cell_m"] = f0.grid.cell_m;
  if (f0.custom_labels) resolved["labels"] = f0.labels_node;
  for (const auto& dir : f0.plugin_dirs) resolved["plugin_path"].push_back(dir);
  resolved["source"] = resolvedEntry(*item.src);
  std::set<std::string> available = {artefacts::kPoints}, names = {item.src->name()};
  auto checkReads = [&](Plugin& pl, const YAML::Mark& mark) {
    for (const auto& r : pl.reads())
      if (!available.count(r))
        d.add(mark, "reads '" + r + "', which no earlier stage writes", pl.name(), pl.type());
  };
  for (const auto& e : stage_entries) {
    Made m = makePlugin(
        reg, e, "stages",
        {PluginKind::kEgomotion, PluginKind::kFeature, PluginKind::kEnergy, PluginKind::kOptimiser},
        ctx, d, false);
    if (!m.ok()) continue;
    if (!names.insert(m.plugin->name()).second)
      d.add(e.Mark(), "duplicate stage name '" + m.plugin->name() + "' (give each a unique name:)",
            m.plugin->name(), m.plugin->type());
    checkReads(*m.plugin, e.Mark());
    for (const auto& w : m.plugin->writes()) available.insert(w);
    resolved["stages"].push_back(resolvedEntry(*m.plugin));
    p.stage_kinds.push_back(m.kind);
    p.stages.emplace_back(static_cast<Stage*>(m.plugin.release()));
  }
  for (const auto& e : output_entries) {
    Made m = makePlugin(reg, e, "outputs", {PluginKind::kOutput}, ctx, d, false);
    if (!m.ok()) continue;
    checkReads(*m.plugin, e.Mark());
    resolved["outputs"].push_back(resolvedEntry(*m.plugin));
    p.outputs.emplace_back(static_cast<Output*>(m.plugin.release()));
  }
  for (auto& o : extra_outputs) {
    checkReads(*o, YAML::Mark::null_mark());
    p.outputs.push_back(std::move(o));
  }
  d.throwIfAny();
  YAML::Emitter em;
  em << resolved;
  p.resolved_yaml = "# Generated from " + f0.file + " (source '" + item.label +
                    "'); runnable with 'terramrf run'.\n" + em.c_str() + "\n";
  return p;
}

RunOptions runOptions(const Item& it, std::ostream* log) {
  RunOptions ro;
  ro.progress = false;
  ro.log = log;
  ro.first = it.first;
  ro.limit = it.count;
  return ro;
}

// ---- training ----------------------------------------------------------------------------------

/// Feeds frames to a feature_stats instance that lives across several pipelines (one per data
/// item) and records which frames it saw.
class StatsFeeder final : public Output {
 public:
  StatsFeeder(Output& stats, TrainedItem& rec, Progress& progress, std::string what)
      : stats_(stats), rec_(rec), progress_(progress), what_(std::move(what)) {
    setIdentity("train_collector", "train_collector");
  }
  std::vector<std::string> reads() const override { return {artefacts::kPoints}; }
  void write(const FrameContext& ctx) override {
    stats_.write(ctx);
    rec_.frame_ids.push_back(ctx.frame->id);
    const auto& t = ctx.frame->truth.label;
    if (!t.empty() && t.size() == ctx.frame->points.size()) ++rec_.labelled_frames;
    progress_.tick(what_ + " " + ctx.frame->id);
  }

 private:
  Output& stats_;
  TrainedItem& rec_;
  Progress& progress_;
  std::string what_;
};

struct TrainJob {
  const Frame0* f0 = nullptr;
  std::vector<YAML::Node> stages;  ///< egomotion + feature entries
  std::vector<Item*> items;
  std::vector<std::string> features;
  YAML::Node stats_params;  ///< extra feature_stats params (min_sigma, min_purity, …)
  YAML::Mark features_mark;
  std::string model_path;
  std::string run_root;  ///< per-item run folders (resolved_config.yaml) and scratch files
  std::string origin;    ///< "config <path>" / "sweep <path>, feature set L"
  std::vector<std::string> held_out;  ///< test items, for the provenance
  std::string what;                   ///< progress prefix
};

/// The model text: the feature_stats file with the provenance replaced by ours.
std::string composeModel(const std::string& stats_text, const TrainJob& job, const TrainResult& r) {
  std::string stats_provenance, classes;
  std::istringstream in(stats_text);
  std::string line;
  bool in_classes = false;
  while (std::getline(in, line)) {
    if (in_classes) {
      classes += line + "\n";
    } else if (line.rfind("classes:", 0) == 0) {
      in_classes = true;
      classes += line + "\n";
    } else if (line.rfind("provenance:", 0) == 0) {
      try {
        stats_provenance = YAML::Load(line)["provenance"].as<std::string>("");
      } catch (const YAML::Exception&) {
        stats_provenance = line.substr(11);
      }
    }
  }
  if (classes.empty()) throw std::runtime_error("feature_stats wrote no 'classes:' section");
  std::string data_text, label_maps;
  std::set<std::string> maps;
  for (const auto& it : r.items) {
    data_text += (data_text.empty() ? "" : "; ") + (it.path.empty() ? it.label : it.path) + " (" +
                 it.frames.str() + ", " + std::to_string(it.frame_ids.size()) + " processed, " +
                 std::to_string(it.labelled_frames) + " labelled)";
    maps.insert(it.label_map);
  }
  for (const auto& m : maps) label_maps += (label_maps.empty() ? "" : ", ") + m;
  std::string feats;
  for (const auto& f : r.features) feats += (feats.empty() ? "" : ", ") + f;
  // feature_stats says "config X, N labelled frame(s), cells with …": keep the cell rule only.
  const std::size_t rule = stats_provenance.find("cells with");
  const std::string cells =
      rule == std::string::npos ? stats_provenance : "training " + stats_provenance.substr(rule);
  const std::string summary = "terramrf train: " + job.origin + "; data " + data_text +
                              "; label map " + label_maps + "; features " + feats + "; " + cells;

  YAML::Emitter em;
  em << YAML::BeginMap;
  em << YAML::Key << "provenance" << YAML::Value << YAML::DoubleQuoted << summary;
  em << YAML::Key << "trained_from" << YAML::Value << YAML::BeginMap;
  em << YAML::Key << "tool" << YAML::Value << std::string("terramrf ") + TERRAMRF_VERSION;
  em << YAML::Key << "date" << YAML::Value << utcNow();
  em << YAML::Key << "origin" << YAML::Value << job.origin;
  em << YAML::Key << "features" << YAML::Value << YAML::Flow << r.features;
  em << YAML::Key << "cells" << YAML::Value << stats_provenance;
  em << YAML::Key << "data" << YAML::Value << YAML::BeginSeq;
  for (const auto& it : r.items) {
    em << YAML::BeginMap;
    em << YAML::Key << "item" << YAML::Value << it.label;
    em << YAML::Key << "source" << YAML::Value << it.source_type;
    if (!it.path.empty()) em << YAML::Key << "path" << YAML::Value << it.path;
    em << YAML::Key << "label_map" << YAML::Value << it.label_map;
    em << YAML::Key << "frames" << YAML::Value << it.frames.str();
    em << YAML::Key << "frame_ids" << YAML::Value << YAML::Flow << it.frame_ids;
    em << YAML::Key << "labelled_frames" << YAML::Value << it.labelled_frames;
    if (it.failed_frames) em << YAML::Key << "failed_frames" << YAML::Value << it.failed_frames;
    em << YAML::EndMap;
  }
  em << YAML::EndSeq;
  if (!job.held_out.empty())
    em << YAML::Key << "held_out" << YAML::Value << YAML::Flow << job.held_out;
  if (!r.missing.empty()) em << YAML::Key << "not_learnt" << YAML::Value << YAML::Flow << r.missing;
  em << YAML::EndMap << YAML::EndMap;
  return "# Per-class Gaussian feature model (paper 000 §4.6), learnt from annotated cells by\n"
         "# 'terramrf train' / 'terramrf compare' with the feature_stats output; loads in "
         "potts_gaussian.\n" +
         std::string(em.c_str()) + "\n" + classes;
}

TrainResult runTraining(TrainJob& job, PluginRegistry& reg, Progress& progress, std::ostream& log) {
  const Frame0& f0 = *job.f0;
  TrainResult r;
  r.model_path = fs::absolute(job.model_path).lexically_normal().string();
  r.features = job.features;
  const std::string model_dir = fs::path(r.model_path).parent_path().string();
  fs::create_directories(model_dir);
  fs::create_directories(job.run_root);
  const std::string tmp = job.run_root + "/feature_stats_model.yaml";

  // The learning itself is the feature_stats output plugin's.
  YAML::Node entry(YAML::NodeType::Map);
  entry["name"] = "feature_stats";
  entry["type"] = "feature_stats";
  YAML::Node params =
      job.stats_params ? YAML::Clone(job.stats_params) : YAML::Node(YAML::NodeType::Map);
  for (const auto& f : job.features) params["features"].push_back(f);
  params["model"] = tmp;
  entry["params"] = params;
  Diags d;
  d.file = f0.file;
  Made m =
      makePlugin(reg, entry, "training", {PluginKind::kOutput}, f0.context(model_dir), d, true);
  if (!m.not_installed.empty())
    throw std::runtime_error("training needs the feature_stats output plugin: " + m.not_installed);
  if (!m.ok()) {
    // The parameters came from the file (training: / min_sigma:): say so.
    for (auto& x : d.list) {
      x.line = job.features_mark.line >= 0 ? job.features_mark.line + 1 : 0;
      x.column = job.features_mark.column + 1;
      x.message = "training: " + x.message;
    }
    throw ConfigError(d.list);
  }
  std::unique_ptr<Output> stats(static_cast<Output*>(m.plugin.release()));
  RunInfo info;
  info.config_path = f0.file;
  info.output_dir = model_dir;
  info.labels = f0.labels.get();
  info.grid = f0.grid;
  for (const Item* it : job.items) info.frames += it->count;
  stats->begin(info);

  for (Item* it : job.items) {
    TrainedItem rec;
    rec.label = it->label;
    rec.source_type = it->type;
    rec.frames = FrameRange{it->first, it->first + it->count - 1};  // after range and --limit
    if (hasParam(*it->src, "path")) rec.path = paramString(*it->src, "path");
    if (hasParam(*it->src, "label_map")) {
      rec.label_map = paramString(*it->src, "label_map");
      if (rec.label_map.empty()) rec.label_map = "(source default)";
    } else {
      rec.label_map = "(none: the source has no label map)";
    }
    std::vector<std::unique_ptr<Output>> extra;
    extra.push_back(std::make_unique<StatsFeeder>(*stats, rec, progress, job.what + it->label));
    Pipeline p = assemble(reg, f0, *it, job.stages, {}, std::move(extra), model_dir);
    // The features must be layers some stage writes.
    std::set<std::string> written;
    for (const auto& s : p.stages)
      for (const auto& w : s->writes()) written.insert(w);
    for (const auto& f : job.features) {
      if (written.count(f)) continue;
      std::string have;
      for (const auto& w : written)
        if (w[0] != '@') have += (have.empty() ? "" : ", ") + w;
      Diags fd;
      fd.file = f0.file;
      fd.add(job.features_mark, "feature '" + f + "' is not written by any stage (written: " +
                                    (have.empty() ? "none" : have) + ")");
      fd.throwIfAny();
    }
    RunResult rr;
    {
      // runPipeline writes resolved_config.yaml into the output folder; keep it per item.
      p.output_dir = job.run_root + "/" + sanitize(it->label);
      SourceLoan loan(*it, p);
      rr = runPipeline(p, runOptions(*it, &log));
    }
    progress.advanceTo(0, job.what + it->label);
    rec.failed_frames = rr.summary.failed.size();
    for (const auto& f : rr.summary.failed) r.failed.push_back(f);
    r.frames += rec.frame_ids.size();
    r.labelled_frames += rec.labelled_frames;
    r.items.push_back(rec);
  }
  if (r.labelled_frames == 0) {
    std::string what;
    for (const auto& it : r.items) what += (what.empty() ? "" : ", ") + it.label;
    throw std::runtime_error("no labelled frame in the training data (" + what +
                             "): a model needs per-point ground truth");
  }
  RunSummary summary;
  summary.frames_ok = r.frames;
  stats->end(summary);
  const std::string text = readFile(tmp);
  std::error_code ec;
  fs::remove(tmp, ec);
  // Which class/feature pairs got no statistics (fewer than two cells).
  try {
    const YAML::Node classes = YAML::Load(text)["classes"];
    for (std::size_t c = 1; c < f0.labels->size(); ++c) {
      const std::string cls = f0.labels->name(static_cast<LabelId>(c));
      for (const auto& f : job.features)
        if (!classes || !classes[cls] || !classes[cls][f]) r.missing.push_back(cls + "." + f);
    }
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(tmp + ": feature_stats wrote an unreadable model: " + e.what());
  }
  writeFileAtomic(r.model_path, composeModel(text, job, r));
  return r;
}

const std::vector<std::string> kConfigKeys = {"version", "plugin_path", "grid",
                                              "labels",  "source",      "stages",
                                              "outputs", "output_dir",  "split"};

std::vector<std::string> stringList(const YAML::Node& n) {
  std::vector<std::string> v;
  if (!n) return v;
  if (n.IsScalar()) v.push_back(n.Scalar());
  if (n.IsSequence())
    for (const auto& e : n) v.push_back(e.Scalar());
  return v;
}

void checkVersion(const YAML::Node& root, Diags& d) {
  if (!root["version"]) {
    d.add(root.Mark(), "missing key 'version' (expected 'version: 1')");
  } else if (root["version"].Scalar() != "1") {
    d.add(root["version"].Mark(),
          "unsupported version '" + root["version"].Scalar() + "' (this build reads version 1)");
  }
}

/// Parses split.train / split.test lists.
void parseSplit(const YAML::Node& split, const std::map<std::string, YAML::Node>* datasets,
                const YAML::Node& base_source, const std::string& base_dir, Diags& d,
                std::vector<std::unique_ptr<Item>>& train, std::vector<std::unique_ptr<Item>>& test,
                bool need_both) {
  if (!split.IsMap()) {
    d.add(split.Mark(), "'split' must be a map {train: [...], test: [...]}");
    return;
  }
  checkKeys(d, split, {"train", "test"}, "split");
  auto list = [&](const char* key, std::vector<std::unique_ptr<Item>>& out) {
    const YAML::Node l = split[key];
    if (!l) {
      if (need_both || std::string(key) == "train")
        d.add(split.Mark(), std::string("split: missing '") + key + ": [...]'");
      return;
    }
    if (!l.IsSequence() || l.size() == 0) {
      d.add(l.Mark(), std::string("split.") + key + ": expected a non-empty list of items");
      return;
    }
    for (const auto& n : l) {
      auto it = std::make_unique<Item>();
      if (parseItem(n, datasets, base_source, base_dir, d, *it)) out.push_back(std::move(it));
    }
  };
  list("train", train);
  list("test", test);
}

/// Unique labels: an item named like another gets its frame range appended.
void uniqueLabels(std::vector<std::unique_ptr<Item>>& items) {
  std::map<std::string, int> n;
  for (const auto& it : items) ++n[it->label];
  for (auto& it : items)
    if (n[it->label] > 1 && it->range_given) {
      it->label += "[" + std::to_string(it->frames.first) + "-" +
                   (it->frames.last == FrameRange::npos ? std::string("end")
                                                        : std::to_string(it->frames.last)) +
                   "]";
    }
}

std::vector<std::string> pluginDirs(const std::vector<std::string>& given) {
  return given.empty() ? PluginRegistry::defaultSearchDirs() : given;
}

}  // namespace

// ================================================================================================
// terramrf train
// ================================================================================================

TrainResult trainModel(const TrainOptions& o) {
  std::ostream& log = o.log ? *o.log : std::cerr;
  if (o.model_out.empty()) throw std::runtime_error("no model file given (--out MODEL)");
  PluginRegistry reg(pluginDirs(o.plugin_dirs));
  Diags d;
  d.file = o.config_path;
  const YAML::Node root = loadYamlFile(o.config_path, d);
  if (!root.IsMap()) {
    d.add(root.Mark(), "expected a pipeline config (a map with version, grid, source, stages)");
    d.throwIfAny();
  }
  checkKeys(d, root, kConfigKeys, "the config");
  checkVersion(root, d);
  Frame0 f0;
  f0.file = o.config_path;
  f0.base_dir = fs::absolute(o.config_path).parent_path().lexically_normal().string();
  readFrame0(root, f0, d, reg);
  const YAML::Node source = root["source"];
  if (!source) d.add(root.Mark(), "missing key 'source' (where the training frames come from)");
  const YAML::Node stages = root["stages"];
  if (!stages || !stages.IsSequence())
    d.add(stages ? stages.Mark() : root.Mark(),
          "'stages' must be a list holding the feature stages to train on");
  d.throwIfAny();

  // Stages: egomotion and feature stages run; energy and optimiser stages are left out (their
  // model may not exist yet). Their feature lists name what to learn when nothing else does.
  TrainJob job;
  job.f0 = &f0;
  job.origin = "config " + fs::absolute(o.config_path).lexically_normal().string();
  std::vector<std::string> energy_features;
  YAML::Mark energy_mark = YAML::Mark::null_mark();
  for (const auto& e : stages) {
    const std::string type = e.IsMap() && e["type"] ? e["type"].Scalar() : "";
    const PluginInfo* info = reg.find(type);
    if (info && (info->kind == PluginKind::kEnergy || info->kind == PluginKind::kOptimiser)) {
      if (info->kind == PluginKind::kEnergy && e["params"] && e["params"]["features"] &&
          energy_features.empty()) {
        energy_features = stringList(e["params"]["features"]);
        energy_mark = e["params"]["features"].Mark();
      }
      continue;
    }
    job.stages.push_back(e);  // unknown types are reported when the pipeline is assembled
  }
  // Features and learning parameters: --features, else a feature_stats output of the config,
  // else the energy stage's features.
  YAML::Node stats_params(YAML::NodeType::Map);
  std::vector<std::string> fs_features;
  YAML::Mark fs_mark = YAML::Mark::null_mark();
  if (const YAML::Node outs = root["outputs"]) {
    for (const auto& e : outs) {
      if (!e.IsMap() || !e["type"] || e["type"].Scalar() != "feature_stats") continue;
      const YAML::Node p = e["params"];
      if (!p || !p.IsMap()) continue;
      for (auto it = p.begin(); it != p.end(); ++it) {
        const std::string k = it->first.Scalar();
        if (k == "features") {
          fs_features = stringList(it->second);
          fs_mark = it->second.Mark();
        } else if (k != "model") {
          stats_params[k] = it->second;
        }
      }
      break;
    }
  }
  if (!o.features.empty()) {
    job.features = o.features;
    job.features_mark = root.Mark();
    if (stats_params["min_sigma"] && stats_params["min_sigma"].IsSequence() &&
        stats_params["min_sigma"].size() != job.features.size() && fs_features != job.features) {
      log << "note: the config's feature_stats min_sigma list is for its own features; using the "
             "plugin default for --features\n";
      stats_params.remove("min_sigma");
    }
  } else if (!fs_features.empty()) {
    job.features = fs_features;
    job.features_mark = fs_mark;
  } else if (!energy_features.empty()) {
    job.features = energy_features;
    job.features_mark = energy_mark;
  } else {
    d.add(root.Mark(),
          "no features to learn: give --features, a feature_stats output with "
          "'features', or an energy stage with 'features'");
    d.throwIfAny();
  }
  job.stats_params = stats_params;

  // Training items: --data folders, else split.train, else the source as it is.
  std::vector<std::unique_ptr<Item>> train, test;
  if (const YAML::Node split = root["split"])
    parseSplit(split, nullptr, source, f0.base_dir, d, train, test, false);
  if (!o.data.empty()) {
    train.clear();
    for (const auto& dir : o.data) {
      const std::string abs = fs::absolute(dir).lexically_normal().string();
      if (!fs::exists(abs)) throw std::runtime_error("--data " + dir + ": folder does not exist");
      auto it = std::make_unique<Item>();
      it->source = YAML::Clone(source);
      if (!it->source["params"] || it->source["params"].IsNull())
        it->source["params"] = YAML::Node(YAML::NodeType::Map);
      it->source["params"]["path"] = abs;
      it->type = it->source["type"] ? it->source["type"].Scalar() : "";
      it->label = abs;
      it->mark = source.Mark();
      train.push_back(std::move(it));
    }
  } else if (train.empty()) {
    auto it = std::make_unique<Item>();
    it->source = YAML::Clone(source);
    it->type = it->source["type"] ? it->source["type"].Scalar() : "";
    it->label = "source";
    it->mark = source.Mark();
    train.push_back(std::move(it));
  }
  d.throwIfAny();
  for (auto& it : train) {
    identify(*it, f0.base_dir, reg);
    if (it->label == "source") it->label = it->identity_text;  // the config's source as it is
  }
  for (auto& it : test) identify(*it, f0.base_dir, reg);
  std::vector<Item*> tr, te;
  for (auto& it : train) tr.push_back(it.get());
  for (auto& it : test) te.push_back(it.get());
  if (!o.data.empty()) {
    // --data items have no position in the file; name them in the message instead.
    Diags od;
    od.file = o.config_path;
    checkDisjoint(tr, te, od);
    for (auto& x : od.list) x.message += " (train item from --data)";
    od.throwIfAny();
  } else {
    checkDisjoint(tr, te, d);
  }
  for (auto& it : test) job.held_out.push_back(it->label + " (" + it->frames.str() + ")");
  d.throwIfAny();

  const std::string model_dir = fs::absolute(o.model_out).parent_path().string();
  for (auto& it : train) {
    prepareItem(*it, reg, f0, model_dir, o.limit, d, false);
    if (it->src) job.items.push_back(it.get());
  }
  d.throwIfAny();
  job.model_path = o.model_out;
  job.what = "train: ";
  // Per-item run folders are scratch here: nothing is left next to the model.
  const fs::path scratch =
      fs::temp_directory_path() /
      ("terramrf_train_" + std::to_string(::getpid()) + "_" +
       std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()));
  job.run_root = scratch.string();
  struct Cleanup {
    fs::path p;
    ~Cleanup() {
      std::error_code ec;
      fs::remove_all(p, ec);
    }
  } cleanup{scratch};
  Progress progress(o.progress);
  std::size_t total = 0;
  for (const Item* it : job.items) total += it->count;
  progress.setTotal(total);
  TrainResult r = runTraining(job, reg, progress, log);
  progress.finish();
  return r;
}

// ================================================================================================
// terramrf compare
// ================================================================================================

namespace {

struct FeatureSet {
  std::string name;
  std::vector<YAML::Node> stages;
  std::vector<std::string> features;
  YAML::Mark features_mark, mark;
  YAML::Node min_sigma;
  std::string model;        ///< given model (absolute), or "" = train
  std::string unavailable;  ///< a stage type is not installed
  int train_group = -1;     ///< index into Sweep::train_groups, -1 = split.train
};

struct OptimiserDef {
  std::string name;
  YAML::Node entry;
  std::string unavailable;
};

struct Sweep {
  std::string file, name, output_dir;
  Frame0 f0;
  std::map<std::string, YAML::Node> datasets;
  std::vector<std::unique_ptr<Item>> train, test;
  /// Feature-set specific training items (`train:` of a feature set), overriding split.train.
  std::vector<std::vector<std::unique_ptr<Item>>> train_groups;
  std::vector<YAML::Node> common_stages;
  std::string common_unavailable;
  std::vector<FeatureSet> feature_sets;
  std::vector<OptimiserDef> optimisers;
  YAML::Node energy;
  std::string energy_unavailable;
  YAML::Node training;  ///< feature_stats params
  YAML::Mark training_mark;
  std::vector<YAML::Node> outputs;
  std::size_t roc_max_points = 500;
  std::string roc_fallback = "local_energy";
  std::vector<std::string> notes;
};

const std::vector<std::string> kSweepKeys = {
    "version",    "name",     "grid",     "labels",        "plugin_path",
    "output_dir", "datasets", "split",    "common_stages", "feature_sets",
    "optimisers", "energy",   "training", "outputs",       "roc"};

/// Parses and validates everything; sources of split items are configured (kept for the runs).
std::unique_ptr<Sweep> loadSweep(const std::string& path, PluginRegistry& reg,
                                 const std::string& output_dir, std::size_t limit) {
  auto s = std::make_unique<Sweep>();
  s->file = path;
  Diags d;
  d.file = path;
  const YAML::Node root = loadYamlFile(path, d);
  if (!root.IsMap()) {
    d.add(root.Mark(),
          "expected a sweep (a map with version, datasets, split, feature_sets, "
          "optimisers)");
    d.throwIfAny();
  }
  checkKeys(d, root, kSweepKeys, "the sweep");
  checkVersion(root, d);
  s->f0.file = path;
  s->f0.base_dir = fs::absolute(path).parent_path().lexically_normal().string();
  readFrame0(root, s->f0, d, reg);
  s->name = root["name"] ? root["name"].Scalar() : fs::path(path).stem().string();
  if (!output_dir.empty()) {
    s->output_dir = fs::absolute(output_dir).lexically_normal().string();
  } else if (root["output_dir"]) {
    s->output_dir = absPath(s->f0.base_dir, root["output_dir"].Scalar());
  } else {
    s->output_dir = (fs::current_path() / "out" / ("compare_" + sanitize(s->name))).string();
  }
  const PluginContext ctx = s->f0.context(s->output_dir);
  const std::vector<PluginKind> stage_kinds = {PluginKind::kEgomotion, PluginKind::kFeature};

  // datasets
  if (const YAML::Node ds = root["datasets"]; ds && ds.IsMap() && ds.size() > 0) {
    for (auto it = ds.begin(); it != ds.end(); ++it) {
      if (!it->second.IsMap() || !it->second["type"]) {
        d.add(it->second.Mark(),
              "dataset '" + it->first.Scalar() + "': expected a source entry {type, params}");
        continue;
      }
      checkKeys(d, it->second, kEntryKeys, "dataset '" + it->first.Scalar() + "'");
      s->datasets[it->first.Scalar()] = it->second;
    }
  } else {
    d.add(ds ? ds.Mark() : root.Mark(),
          "'datasets' must be a non-empty map name: {type, params} (source entries)");
  }
  // split
  if (const YAML::Node split = root["split"]) {
    parseSplit(split, &s->datasets, YAML::Node(), s->f0.base_dir, d, s->train, s->test, true);
  } else {
    d.add(root.Mark(),
          "missing key 'split' ({train: [...], test: [...]}); train and test sets "
          "are never implied");
  }
  uniqueLabels(s->test);
  uniqueLabels(s->train);
  // common stages
  auto stageList = [&](const YAML::Node& l, const std::string& what, std::vector<YAML::Node>& out,
                       std::string& unavailable) {
    if (!l) return;
    if (!l.IsSequence()) {
      d.add(l.Mark(), what + ": expected a list of stage entries {name, type, params}");
      return;
    }
    for (const auto& e : l) {
      Made m = makePlugin(reg, e, what, stage_kinds, ctx, d, true);
      if (!m.not_installed.empty() && unavailable.empty()) unavailable = m.not_installed;
      out.push_back(e);
    }
  };
  stageList(root["common_stages"], "common_stages", s->common_stages, s->common_unavailable);
  // feature sets
  if (const YAML::Node fsn = root["feature_sets"]; fsn && fsn.IsMap() && fsn.size() > 0) {
    for (auto it = fsn.begin(); it != fsn.end(); ++it) {
      FeatureSet f;
      f.name = it->first.Scalar();
      f.mark = it->first.Mark();
      const YAML::Node v = it->second;
      const std::string what = "feature set '" + f.name + "'";
      if (!v.IsMap()) {
        d.add(v.Mark(), what + ": expected {stages: [...], features: [...]}");
        continue;
      }
      checkKeys(d, v, {"extends", "stages", "features", "min_sigma", "model", "train"}, what);
      // extends: an earlier feature set's stages, features and σ floors come first.
      if (const YAML::Node ex = v["extends"]) {
        const FeatureSet* base = nullptr;
        for (const auto& b : s->feature_sets)
          if (b.name == ex.Scalar()) base = &b;
        if (!base) {
          std::vector<std::string> names;
          for (const auto& b : s->feature_sets) names.push_back(b.name);
          std::string m =
              what + ": extends '" + ex.Scalar() + "', which is not an earlier feature set";
          const std::string dym = detail::didYouMean(ex.Scalar(), names);
          if (!dym.empty()) m += " (did you mean '" + dym + "'?)";
          d.add(ex.Mark(), m);
        } else {
          f.stages = base->stages;
          f.features = base->features;
          f.features_mark = base->features_mark;
          f.unavailable = base->unavailable;
          f.train_group = base->train_group;
          f.min_sigma.reset(base->min_sigma);
        }
      }
      stageList(v["stages"], what + " stages", f.stages, f.unavailable);
      if (v["features"]) {
        for (const auto& x : stringList(v["features"])) f.features.push_back(x);
        f.features_mark = v["features"].Mark();
      }
      if (f.features.empty())
        d.add(v.Mark(), what + ": 'features' must list the feature layers the energy uses");
      if (const YAML::Node ms = v["min_sigma"]) {
        if (f.min_sigma && f.min_sigma.IsSequence() && ms.IsSequence()) {
          YAML::Node joined = YAML::Clone(f.min_sigma);
          for (const auto& x : ms) joined.push_back(YAML::Node(x));
          f.min_sigma.reset(joined);
        } else {
          f.min_sigma.reset(ms);
        }
      }
      // One σ floor for all features, or one per feature (extends: the base's come first).
      if (f.min_sigma && f.min_sigma.IsSequence() && f.min_sigma.size() > 1 &&
          f.min_sigma.size() != f.features.size())
        d.add(v["min_sigma"] ? v["min_sigma"].Mark() : v.Mark(),
              what + ": min_sigma has " + std::to_string(f.min_sigma.size()) + " values for " +
                  std::to_string(f.features.size()) +
                  " features (with those of 'extends'); give one value, or one per feature");
      if (const YAML::Node tr = v["train"]) {
        if (!tr.IsSequence() || tr.size() == 0) {
          d.add(tr.Mark(), what + ": 'train' must be a non-empty list of split items");
        } else {
          std::vector<std::unique_ptr<Item>> group;
          for (const auto& n : tr) {
            auto item = std::make_unique<Item>();
            if (parseItem(n, &s->datasets, YAML::Node(), s->f0.base_dir, d, *item))
              group.push_back(std::move(item));
          }
          s->train_groups.push_back(std::move(group));
          f.train_group = static_cast<int>(s->train_groups.size()) - 1;
        }
      }
      if (v["model"]) {
        f.model = absPath(s->f0.base_dir, v["model"].Scalar());
        if (!fs::exists(f.model))
          d.add(v["model"].Mark(), what + ": model '" + f.model + "' does not exist");
      }
      // Every feature must be written by a stage (checked when every stage type is installed).
      if (f.unavailable.empty() && s->common_unavailable.empty()) {
        std::set<std::string> written;
        Diags quiet;
        quiet.file = path;
        for (const auto* list : {&s->common_stages, &f.stages})
          for (const auto& e : *list) {
            Made m = makePlugin(reg, e, "stages", stage_kinds, ctx, quiet, true);
            if (m.ok())
              for (const auto& w : m.plugin->writes()) written.insert(w);
          }
        if (quiet.list.empty())
          for (const auto& feat : f.features)
            if (!written.count(feat)) {
              std::string have;
              for (const auto& w : written)
                if (w[0] != '@') have += (have.empty() ? "" : ", ") + w;
              d.add(f.features_mark, what + ": feature '" + feat +
                                         "' is not written by any of its or the common stages "
                                         "(written: " +
                                         (have.empty() ? "none" : have) + ")");
            }
      }
      s->feature_sets.push_back(std::move(f));
    }
  } else {
    d.add(root["feature_sets"] ? root["feature_sets"].Mark() : root.Mark(),
          "'feature_sets' must be a non-empty map name: {stages, features}");
  }
  // optimisers
  if (const YAML::Node on = root["optimisers"];
      on && (on.IsMap() || on.IsSequence()) && on.size() > 0) {
    auto add = [&](const std::string& name, const YAML::Node& entry) {
      OptimiserDef od;
      od.name = name;
      od.entry = entry;
      Made m = makePlugin(reg, entry, "optimiser '" + name + "'", {PluginKind::kOptimiser}, ctx, d,
                          true);
      od.unavailable = m.not_installed;
      s->optimisers.push_back(od);
    };
    if (on.IsMap()) {
      for (auto it = on.begin(); it != on.end(); ++it) {
        YAML::Node e = it->second;
        if (e.IsScalar()) {  // name: type
          YAML::Node m(YAML::NodeType::Map);
          m["type"] = e;
          e.reset(m);
        }
        if (e.IsMap() && !e["name"]) {
          e.reset(YAML::Clone(e));
          e["name"] = it->first.Scalar();
        }
        add(it->first.Scalar(), e);
      }
    } else {
      for (const auto& item : on) {
        const YAML::Node e = item;
        if (e.IsScalar()) {
          YAML::Node m(YAML::NodeType::Map);
          m["type"] = e.Scalar();
          add(e.Scalar(), m);
        } else {
          add(e["name"] ? e["name"].Scalar() : (e["type"] ? e["type"].Scalar() : "?"), e);
        }
      }
    }
  } else {
    d.add(root["optimisers"] ? root["optimisers"].Mark() : root.Mark(),
          "'optimisers' must name at least one optimiser (e.g. {icm: {type: icm}})");
  }
  // energy
  if (const YAML::Node en = root["energy"]) {
    s->energy = YAML::Clone(en);
    if (en.IsMap() && en["params"] && en["params"].IsMap())
      for (const char* k : {"model", "features"})
        if (en["params"][k])
          d.add(en["params"][k].Mark(), std::string("energy: '") + k +
                                            "' is set per feature set by compare; remove it here");
  } else {
    s->energy = YAML::Load("{name: mrf, type: potts_gaussian}");
  }
  if (!s->energy.IsMap()) {
    d.add(s->energy.Mark(), "'energy' must be an entry {name, type, params}");
  } else {
    if (!s->energy["name"]) s->energy["name"] = "mrf";
    Made m = makePlugin(reg, s->energy, "energy", {PluginKind::kEnergy}, ctx, d, true, false);
    s->energy_unavailable = m.not_installed;
  }
  // training, outputs, roc
  if (const YAML::Node tr = root["training"]) {
    if (!tr.IsMap()) {
      d.add(tr.Mark(), "'training' must be a map of feature_stats parameters");
    } else {
      checkKeys(d, tr, {"min_purity", "min_labelled_points", "min_sigma", "estimator", "obstacle_rule"}, "training");
      s->training = tr;
      s->training_mark = tr.Mark();
    }
  }
  if (const YAML::Node out = root["outputs"]) {
    if (!out.IsSequence()) {
      d.add(out.Mark(), "'outputs' must be a list of output entries (added to every test run)");
    } else {
      for (const auto& e : out) {
        makePlugin(reg, e, "outputs", {PluginKind::kOutput}, ctx, d, false);
        s->outputs.push_back(e);
      }
    }
  }
  if (const YAML::Node roc = root["roc"]) {
    if (!roc.IsMap()) {
      d.add(roc.Mark(), "'roc' must be a map {max_points, fallback}");
    } else {
      checkKeys(d, roc, {"max_points", "fallback"}, "roc");
      if (roc["max_points"]) {
        try {
          const int v = roc["max_points"].as<int>();
          if (v < 2) throw YAML::Exception(roc["max_points"].Mark(), "");
          s->roc_max_points = static_cast<std::size_t>(v);
        } catch (const YAML::Exception&) {
          d.add(roc["max_points"].Mark(), "roc.max_points: expected an integer >= 2");
        }
      }
      if (roc["fallback"]) {
        s->roc_fallback = roc["fallback"].Scalar();
        if (s->roc_fallback != "local_energy" && s->roc_fallback != "skip")
          d.add(roc["fallback"].Mark(),
                "roc.fallback: expected 'local_energy' or 'skip', got '" + s->roc_fallback + "'");
      }
    }
  }
  d.throwIfAny();

  // Disjoint split, then the sources (configured once, reused by every run).
  for (auto& it : s->train) identify(*it, s->f0.base_dir, reg);
  for (auto& it : s->test) identify(*it, s->f0.base_dir, reg);
  for (auto& g : s->train_groups)
    for (auto& it : g) identify(*it, s->f0.base_dir, reg);
  std::vector<Item*> tr, te;
  for (auto& it : s->train) tr.push_back(it.get());
  for (auto& g : s->train_groups)
    for (auto& it : g) tr.push_back(it.get());
  for (auto& it : s->test) te.push_back(it.get());
  checkDisjoint(tr, te, d);
  d.throwIfAny();
  for (auto& it : s->train) prepareItem(*it, reg, s->f0, s->output_dir, limit, d, true);
  for (auto& g : s->train_groups)
    for (auto& it : g) prepareItem(*it, reg, s->f0, s->output_dir, limit, d, true);
  for (auto& it : s->test) prepareItem(*it, reg, s->f0, s->output_dir, limit, d, true);
  std::set<std::string> used;
  for (auto& it : s->train) used.insert(it->dataset);
  for (auto& g : s->train_groups)
    for (auto& it : g) used.insert(it->dataset);
  for (auto& it : s->test) used.insert(it->dataset);
  for (const auto& [name, node] : s->datasets)
    if (!used.count(name))
      s->notes.push_back("dataset '" + name + "' is in neither split.train nor split.test");
  d.throwIfAny();
  return s;
}

/// The items a feature set trains on.
const std::vector<std::unique_ptr<Item>>& trainItems(const Sweep& s, const FeatureSet& f) {
  return f.train_group >= 0 ? s.train_groups[f.train_group] : s.train;
}

std::string trainUnavailable(const Sweep& s, const FeatureSet& f) {
  if (!f.model.empty()) return "";
  for (const auto& it : trainItems(s, f))
    if (!it->unavailable.empty()) return "train item '" + it->label + "': " + it->unavailable;
  return "";
}

/// Why a run cannot be made ("" = it can).
std::string skipReason(const Sweep& s, const Item& test, const FeatureSet& f,
                       const OptimiserDef& o) {
  if (!test.unavailable.empty()) return "dataset '" + test.label + "': " + test.unavailable;
  if (!s.common_unavailable.empty()) return "common stages: " + s.common_unavailable;
  if (!f.unavailable.empty()) return "feature set '" + f.name + "': " + f.unavailable;
  if (!s.energy_unavailable.empty()) return "energy: " + s.energy_unavailable;
  if (!o.unavailable.empty()) return "optimiser '" + o.name + "': " + o.unavailable;
  const std::string t = trainUnavailable(s, f);
  if (!t.empty()) return "no model for feature set '" + f.name + "': " + t;
  return "";
}

/// Collects evaluation, ROC samples, energies of one run; ticks the progress bar.
class RunCollector final : public Output {
 public:
  RunCollector(const LabelSet& labels, bool energy_fallback, RunRecord& rec, Progress& progress,
               std::string what)
      : evaluator_(labels),
        roc_(labels),
        energy_fallback_(energy_fallback),
        rec_(rec),
        progress_(progress),
        what_(std::move(what)) {
    setIdentity("compare_collector", "compare_collector");
  }
  std::vector<std::string> reads() const override {
    return {artefacts::kPoints, artefacts::kLabels};
  }
  void write(const FrameContext& ctx) override {
    const TerrainGrid& g = *ctx.grid;
    const Frame& fr = *ctx.frame;
    const EvalCounts frame_counts = evaluator_.addFrame(g, fr);
    if (frame_counts.scans) rec_.per_scan.emplace_back(fr.id, frame_counts);
    const RocFrameStats st = roc_.addFrame(
        g, fr, energy_fallback_ ? &ctx.energy : static_cast<const EnergyModel*>(nullptr));
    if (st.source != ScoreSource::kNone) sources_.insert(st.source);
    FrameEnergy e;
    e.frame = fr.id;
    e.initial = ctx.optimiser.initial_energy;
    e.reported = ctx.optimiser.final_energy;
    e.iterations = ctx.optimiser.iterations;
    e.converged = ctx.optimiser.converged;
    e.recomputed = recompute(ctx.energy, g.labels());
    rec_.energies.push_back(e);
    progress_.tick(what_ + " " + fr.id);
  }
  void end(const RunSummary&) override {
    rec_.counts = evaluator_.total();
    rec_.roc = roc_.curves(max_points_);
    if (sources_.count(ScoreSource::kScoreLayers))
      rec_.score_source = ScoreSource::kScoreLayers;
    else if (sources_.count(ScoreSource::kLocalEnergy))
      rec_.score_source = ScoreSource::kLocalEnergy;
    std::ostringstream note;
    if (rec_.counts.scans == 0) {
      note << "no frame with per-point ground truth: nothing to score";
    } else if (sources_.empty()) {
      note << "no ROC: the optimiser wrote no score layers"
           << (energy_fallback_ ? " and there was no energy model" : " (roc.fallback: skip)");
    } else {
      if (roc_.frames_with_layers)
        note << roc_.frames_with_layers << " frame(s) scored from score layers";
      if (roc_.frames_with_energy_fallback)
        note << (roc_.frames_with_layers ? "; " : "") << roc_.frames_with_energy_fallback
             << " frame(s) from the local energy margin (the optimiser wrote no score layers)";
      if (roc_.frames_without_scores)
        note << "; " << roc_.frames_without_scores << " frame(s) without scores";
      if (roc_.cells_without_score)
        note << "; " << roc_.cells_without_score << " of " << roc_.cells_scored
             << " scored cells had no score";
    }
    rec_.roc_note = note.str();
  }
  void setMaxPoints(std::size_t n) { max_points_ = n; }

 private:
  static double recompute(const EnergyModel& em, const std::vector<LabelId>& labels) {
    if (em.empty() || em.cells() != labels.size()) return kNaN;
    std::vector<int> index_of(256, -1);
    for (int k = 0; k < em.numLabels(); ++k) index_of[em.active[k]] = k;
    std::vector<uint8_t> lab(em.cells(), 0);
    for (std::size_t i = 0; i < em.cells(); ++i) {
      if (em.fixed[i]) continue;
      const int k = index_of[labels[i]];
      if (k < 0) return kNaN;  // a label the model cannot express
      lab[i] = static_cast<uint8_t>(k);
    }
    return em.energy(lab);
  }

  Evaluator evaluator_;
  RocAccumulator roc_;
  bool energy_fallback_;
  RunRecord& rec_;
  Progress& progress_;
  std::string what_;
  std::set<ScoreSource> sources_;
  std::size_t max_points_ = 500;
};

RunTimes runTimes(const RunResult& r, const Pipeline& p) {
  std::set<std::string> mrf, feature;
  for (std::size_t i = 0; i < p.stages.size(); ++i) {
    const PluginKind k = p.stage_kinds[i];
    (k == PluginKind::kEnergy || k == PluginKind::kOptimiser ? mrf : feature)
        .insert(p.stages[i]->name());
  }
  RunTimes t;
  std::size_t n = 0;
  for (const auto& s : r.timings) n = std::max(n, s.ms.size());
  t.processing.assign(n, 0);
  t.features.assign(n, 0);
  t.mrf.assign(n, 0);
  t.total.assign(n, 0);
  for (const auto& s : r.timings) {
    if (s.ms.size() != n) continue;
    const bool is_total = s.name == "total";
    const bool is_io = s.name == "read" || s.name.rfind("output:", 0) == 0;
    for (std::size_t f = 0; f < n; ++f) {
      if (is_total) {
        t.total[f] = s.ms[f];
        continue;
      }
      if (is_io) continue;
      t.processing[f] += s.ms[f];
      if (mrf.count(s.name))
        t.mrf[f] += s.ms[f];
      else
        t.features[f] += s.ms[f];  // grid + egomotion + features
    }
  }
  return t;
}

}  // namespace

SweepPlan planSweep(const std::string& sweep_path, const std::vector<std::string>& plugin_dirs) {
  PluginRegistry reg(pluginDirs(plugin_dirs));
  auto s = loadSweep(sweep_path, reg, "", 0);
  SweepPlan plan;
  plan.name = s->name;
  for (const auto& t : s->test)
    for (const auto& f : s->feature_sets)
      for (const auto& o : s->optimisers) {
        const std::string run = t->label + " × " + f.name + " × " + o.name;
        const std::string why = skipReason(*s, *t, f, o);
        if (why.empty())
          plan.runs.push_back(run);
        else
          plan.skipped.push_back({run, why});
      }
  return plan;
}

const RunRecord* SweepResult::find(const std::string& dataset, const std::string& feature_set,
                                   const std::string& optimiser) const {
  for (const auto& r : runs)
    if (r.dataset == dataset && r.feature_set == feature_set && r.optimiser == optimiser) return &r;
  return nullptr;
}

int SweepResult::exitCode() const {
  for (const auto& r : runs)
    if (r.status == RunRecord::Status::kFailed || !r.failed.empty()) return 3;
  return 0;
}

SweepResult runSweep(const CompareOptions& o) {
  std::ostream& log = o.log ? *o.log : std::cerr;
  PluginRegistry reg(pluginDirs(o.plugin_dirs));
  auto s = loadSweep(o.sweep_path, reg, o.output_dir, o.limit);
  for (const auto& n : s->notes) log << "note: " << n << "\n";
  SweepResult res;
  res.name = s->name;
  res.sweep_path = fs::absolute(o.sweep_path).lexically_normal().string();
  res.output_dir = s->output_dir;
  res.labels = *s->f0.labels;
  res.limit = o.limit;
  for (const auto& t : s->test) res.datasets.push_back(t->label);
  for (const auto& f : s->feature_sets) res.feature_sets.push_back(f.name);
  for (const auto& op : s->optimisers) res.optimisers.push_back(op.name);
  for (const auto& t : s->train) res.train_items.push_back(t->label + " (" + t->frames.str() + ")");
  fs::create_directories(s->output_dir);
  writeFileAtomic(s->output_dir + "/sweep.yaml", readFile(o.sweep_path));

  // Progress total: training frames of every feature set that trains, test frames of every run.
  Progress progress(o.progress);
  std::size_t total = 0;
  std::vector<std::string> fs_train_reason(s->feature_sets.size());
  for (std::size_t i = 0; i < s->feature_sets.size(); ++i) {
    const auto& f = s->feature_sets[i];
    if (!f.model.empty()) continue;
    std::string why = trainUnavailable(*s, f);
    if (why.empty() && !f.unavailable.empty()) why = f.unavailable;
    if (why.empty() && !s->common_unavailable.empty()) why = s->common_unavailable;
    fs_train_reason[i] = why;
    if (why.empty())
      for (const auto& t : trainItems(*s, f)) total += t->count;
  }
  for (const auto& t : s->test)
    for (const auto& f : s->feature_sets)
      for (const auto& op : s->optimisers)
        if (skipReason(*s, *t, f, op).empty()) total += t->count;
  progress.setTotal(total);
  std::size_t done = 0;

  // 1. One model per feature set.
  std::vector<std::string> model_of(s->feature_sets.size());
  std::vector<bool> train_failed(s->feature_sets.size(), false);
  for (std::size_t i = 0; i < s->feature_sets.size(); ++i) {
    const FeatureSet& f = s->feature_sets[i];
    ModelRecord mr;
    mr.feature_set = f.name;
    if (!f.model.empty()) {
      mr.path = f.model;
      mr.reason = "given in the sweep";
    } else if (!fs_train_reason[i].empty()) {
      mr.reason = "not trained: " + fs_train_reason[i];
    } else {
      TrainJob job;
      job.f0 = &s->f0;
      job.stages = s->common_stages;
      job.stages.insert(job.stages.end(), f.stages.begin(), f.stages.end());
      for (auto& t : trainItems(*s, f)) {
        job.items.push_back(t.get());
        mr.train_items.push_back(t->label + " (" + t->frames.str() + ")");
      }
      job.features = f.features;
      job.features_mark = f.features_mark;
      job.stats_params = s->training ? YAML::Clone(s->training) : YAML::Node(YAML::NodeType::Map);
      if (f.min_sigma) job.stats_params["min_sigma"] = f.min_sigma;
      job.model_path = s->output_dir + "/models/" + sanitize(f.name) + ".yaml";
      job.run_root = s->output_dir + "/models/" + sanitize(f.name) + ".train";
      job.origin = "sweep " + res.sweep_path + ", feature set " + f.name;
      for (const auto& t : s->test) job.held_out.push_back(t->label + " (" + t->frames.str() + ")");
      job.what = "train " + f.name + ": ";
      try {
        const TrainResult tr = runTraining(job, reg, progress, log);
        mr.path = tr.model_path;
        mr.trained = true;
        mr.frames = tr.frames;
        mr.labelled_frames = tr.labelled_frames;
        mr.missing = tr.missing;
        if (!tr.missing.empty()) {
          progress.breakLine();
          log << "note: feature set " << f.name << ": no statistics for";
          for (const auto& m : tr.missing) log << " " << m;
          log << " (fewer than two training cells)\n";
        }
      } catch (const ConfigError&) {
        throw;
      } catch (const std::exception& e) {
        mr.reason = std::string("training failed: ") + e.what();
        train_failed[i] = true;
        progress.breakLine();
        log << "feature set " << f.name << ": " << mr.reason << "\n";
      }
      for (const auto& t : trainItems(*s, f)) done += t->count;
      progress.advanceTo(done, "trained " + f.name);
    }
    model_of[i] = mr.path;
    res.models.push_back(mr);
  }

  // 2. Every test item × feature set × optimiser.
  for (auto& tptr : s->test) {
    Item& t = *tptr;
    for (std::size_t fi = 0; fi < s->feature_sets.size(); ++fi) {
      const FeatureSet& f = s->feature_sets[fi];
      for (const auto& op : s->optimisers) {
        RunRecord rec;
        rec.dataset = t.label;
        rec.feature_set = f.name;
        rec.optimiser = op.name;
        rec.frames = t.count;
        rec.counts = EvalCounts(res.labels.size());
        rec.reason = skipReason(*s, t, f, op);
        if (!rec.reason.empty()) {
          rec.status = RunRecord::Status::kSkipped;
          res.runs.push_back(std::move(rec));
          continue;
        }
        if (model_of[fi].empty()) {
          rec.status = train_failed[fi] ? RunRecord::Status::kFailed : RunRecord::Status::kSkipped;
          rec.reason = "no model for feature set '" + f.name + "': " + res.models[fi].reason;
          res.runs.push_back(std::move(rec));
          continue;
        }
        rec.output_dir = s->output_dir + "/runs/" + sanitize(rec.key());
        const std::string what = t.label + " × " + f.name + " × " + op.name + ":";
        try {
          std::vector<YAML::Node> stages = s->common_stages;
          stages.insert(stages.end(), f.stages.begin(), f.stages.end());
          YAML::Node energy = YAML::Clone(s->energy);
          if (!energy["params"] || energy["params"].IsNull())
            energy["params"] = YAML::Node(YAML::NodeType::Map);
          energy["params"]["model"] = model_of[fi];
          for (const auto& feat : f.features) energy["params"]["features"].push_back(feat);
          stages.push_back(energy);
          stages.push_back(op.entry);
          std::vector<std::unique_ptr<Output>> extra;
          auto collector = std::make_unique<RunCollector>(
              res.labels, s->roc_fallback == "local_energy", rec, progress, what);
          collector->setMaxPoints(s->roc_max_points);
          extra.push_back(std::move(collector));
          Pipeline p =
              assemble(reg, s->f0, t, stages, s->outputs, std::move(extra), rec.output_dir);
          RunResult rr;
          {
            SourceLoan loan(t, p);
            rr = runPipeline(p, runOptions(t, &log));
          }
          rec.frames_ok = rr.summary.frames_ok;
          rec.failed = rr.summary.failed;
          rec.times = runTimes(rr, p);
          writeFileAtomic(rec.output_dir + "/timing.md", timingTable(rr));
          if (rr.frames_total > 0 && rr.summary.frames_ok == 0) {
            rec.status = RunRecord::Status::kFailed;
            rec.reason = "every frame failed";
            if (!rr.summary.failed.empty())
              rec.reason += " (first: " + rr.summary.failed[0].second + ")";
          }
          for (const auto& e : rr.output_errors) {
            rec.status = RunRecord::Status::kFailed;
            rec.reason += (rec.reason.empty() ? "" : "; ") + e;
          }
          if (!rec.failed.empty()) {
            progress.breakLine();
            log << what << " " << rec.failed.size() << " frame(s) failed and were skipped\n";
          }
        } catch (const ConfigError& e) {
          rec.status = RunRecord::Status::kFailed;
          rec.reason = e.what();
        } catch (const std::exception& e) {
          rec.status = RunRecord::Status::kFailed;
          rec.reason = e.what();
        }
        if (rec.status == RunRecord::Status::kFailed) {
          progress.breakLine();
          log << what << " failed: " << rec.reason << "\n";
        }
        done += t.count;
        progress.advanceTo(done, what + " done");
        res.runs.push_back(std::move(rec));
      }
    }
  }
  progress.finish();
  writeSweepReport(res, s->output_dir);
  return res;
}

// ================================================================================================
// Reports
// ================================================================================================

namespace {

std::vector<LabelId> scoredClasses(const LabelSet& l) {
  std::vector<LabelId> v;
  for (std::size_t c = 1; c < l.size(); ++c) v.push_back(static_cast<LabelId>(c));
  return v;
}

std::string pct(double v) { return fmt("%.1f %%", 100.0 * v); }

std::string statusCell(const RunRecord* r) {
  if (!r) return "–";
  if (r->status == RunRecord::Status::kSkipped) return "skipped";
  if (r->status == RunRecord::Status::kFailed) return "failed";
  return "";
}

const char* statusName(RunRecord::Status s) {
  switch (s) {
    case RunRecord::Status::kOk:
      return "ok";
    case RunRecord::Status::kSkipped:
      return "skipped";
    case RunRecord::Status::kFailed:
      return "failed";
  }
  return "?";
}

/// Relative tolerance when comparing energies of different optimisers (float unaries summed in
/// double: differences below this are rounding, not a better labelling).
bool energyLeq(double a, double b) {
  return a <= b + 1e-6 * std::max({1.0, std::fabs(a), std::fabs(b)});
}

std::string energiesSection(const SweepResult& r) {
  std::ostringstream o;
  o << "## Final energies\n\n"
       "Energy of the labelling each optimiser returned, recomputed from the energy model "
       "(`reported` is what the optimiser put in its report). Lower is better; all optimisers "
       "of a row minimise the same energy.\n\n";
  bool any = false;
  for (const auto& ds : r.datasets)
    for (const auto& fset : r.feature_sets) {
      std::vector<const RunRecord*> runs;
      for (const auto& op : r.optimisers) {
        const RunRecord* x = r.find(ds, fset, op);
        if (x && x->status == RunRecord::Status::kOk && !x->energies.empty()) runs.push_back(x);
      }
      if (runs.empty()) continue;
      any = true;
      o << "### " << ds << " × " << fset << "\n\n| scan |";
      for (const auto* x : runs) o << " " << x->optimiser << " |";
      o << " lowest |\n|---|";
      for (std::size_t i = 0; i < runs.size(); ++i) o << "---:|";
      o << "---|\n";
      std::map<std::string, std::map<std::string, double>> by_frame;  // frame → optimiser → E
      std::vector<std::string> frames;
      for (const auto* x : runs)
        for (const auto& e : x->energies) {
          if (!by_frame.count(e.frame)) frames.push_back(e.frame);
          by_frame[e.frame][x->optimiser] = e.recomputed;
        }
      std::map<std::string, std::size_t> lowest_count;
      std::size_t complete = 0;
      for (const auto& fr : frames) {
        o << "| " << fr << " |";
        const auto& m = by_frame[fr];
        for (const auto* x : runs) {
          auto it = m.find(x->optimiser);
          o << " " << (it == m.end() ? std::string("–") : fmt("%.3f", it->second)) << " |";
        }
        std::string lowest;
        if (m.size() == runs.size()) {
          ++complete;
          for (const auto* x : runs) {
            bool leq = true;
            for (const auto* y : runs)
              if (!energyLeq(m.at(x->optimiser), m.at(y->optimiser))) leq = false;
            if (leq) {
              ++lowest_count[x->optimiser];
              lowest += (lowest.empty() ? "" : ", ") + x->optimiser;
            }
          }
        }
        o << " " << (lowest.empty() ? "–" : lowest) << " |\n";
      }
      o << "\n";
      if (runs.size() > 1)
        for (const auto* x : runs)
          o << "- " << x->optimiser << " ≤ every other optimiser on " << lowest_count[x->optimiser]
            << " of " << complete << " scan(s)\n";
      o << "\n";
    }
  if (!any) o << "No run produced energies.\n\n";
  return o.str();
}

std::string evaluationSection(const SweepResult& r) {
  std::ostringstream o;
  o << "## Point-wise and cell-wise evaluation (paper 001 §VI-B)\n\n";
  for (const auto& x : r.runs) {
    o << "### " << x.dataset << " × " << x.feature_set << " × " << x.optimiser << "\n\n";
    if (x.status != RunRecord::Status::kOk) {
      o << "**" << statusName(x.status) << "**: " << x.reason << "\n\n";
      continue;
    }
    if (x.counts.scans == 0) {
      o << "Not scored: " << x.counts.frames_without_truth
        << " frame(s) without per-point ground truth.\n\n";
      continue;
    }
    o << toTable(x.counts, r.labels) << "\n";
  }
  return o.str();
}

std::string rocSection(const SweepResult& r) {
  std::ostringstream o;
  o << "## ROC curves (cell-wise, paper 000 Figure 6)\n\n"
       "| dataset | feature set | optimiser | scores | ";
  const auto classes = scoredClasses(r.labels);
  for (LabelId c : classes) o << capitalise(r.labels.name(c)) << " AUC | ";
  o << "plot |\n|---|---|---|---|";
  for (std::size_t i = 0; i < classes.size(); ++i) o << "---:|";
  o << "---|\n";
  for (const auto& x : r.runs) {
    if (x.status != RunRecord::Status::kOk) continue;
    o << "| " << x.dataset << " | " << x.feature_set << " | " << x.optimiser << " | "
      << (x.roc.empty() ? "none" : toString(x.score_source)) << " | ";
    for (LabelId c : classes) {
      double auc = kNaN;
      for (const auto& cv : x.roc)
        if (cv.class_id == c) auc = cv.auc;
      o << fmt("%.3f", auc) << " | ";
    }
    o << (x.roc.empty() ? std::string("–") : "[svg](roc/" + sanitize(x.key()) + ".svg)") << " |\n";
  }
  o << "\n";
  for (const auto& x : r.runs)
    if (x.status == RunRecord::Status::kOk && !x.roc_note.empty())
      o << "- " << x.dataset << " × " << x.feature_set << " × " << x.optimiser << ": " << x.roc_note
        << "\n";
  o << "\n";
  return o.str();
}

std::string runsSection(const SweepResult& r) {
  std::ostringstream o;
  o << "## Runs\n\n| dataset | feature set | optimiser | status | scans ok | note |\n"
       "|---|---|---|---|---:|---|\n";
  for (const auto& x : r.runs) {
    std::string note = x.reason;
    for (auto& ch : note)
      if (ch == '\n' || ch == '|') ch = ' ';
    o << "| " << x.dataset << " | " << x.feature_set << " | " << x.optimiser << " | "
      << statusName(x.status) << " | " << x.frames_ok << "/" << x.frames << " | " << note << " |\n";
  }
  o << "\n## Models\n\n| feature set | model | trained on |\n|---|---|---|\n";
  for (const auto& m : r.models) {
    o << "| " << m.feature_set << " | " << (m.path.empty() ? "–" : m.path) << " | ";
    for (const auto& t : m.train_items) o << t << "; ";
    if (m.trained)
      o << m.labelled_frames << " labelled of " << m.frames << " frame(s)";
    else
      o << m.reason;
    if (!m.missing.empty()) {
      o << "; not learnt:";
      for (const auto& x : m.missing) o << " " << x;
    }
    o << " |\n";
  }
  o << "\n";
  return o.str();
}

std::string accuracyCsv(const SweepResult& r) {
  std::ostringstream o;
  o << "dataset,optimiser,feature_set,status,class,cell_tpr,cell_fpr,point_tpr,point_fpr\n";
  for (const auto& x : r.runs)
    for (LabelId c : scoredClasses(r.labels)) {
      const bool ok = x.status == RunRecord::Status::kOk;
      const ClassScores cs = x.counts.cell_wise.scores(c), ps = x.counts.point_wise.scores(c);
      o << csvStr(x.dataset) << "," << csvStr(x.optimiser) << "," << csvStr(x.feature_set) << ","
        << statusName(x.status) << "," << r.labels.name(c) << "," << (ok ? csvNum(cs.tpr()) : "")
        << "," << (ok ? csvNum(cs.fpr()) : "") << "," << (ok ? csvNum(ps.tpr()) : "") << ","
        << (ok ? csvNum(ps.fpr()) : "") << "\n";
    }
  return o.str();
}

std::string evaluationCsv(const SweepResult& r) {
  std::ostringstream o;
  o << "dataset,optimiser,feature_set,status,level,class,tp,fp,fn,tn,precision,recall,tpr,fpr,"
       "scans,points,labelled_points,classified_points,cells_scored\n";
  for (const auto& x : r.runs) {
    if (x.status != RunRecord::Status::kOk) continue;
    for (const char* level : {"point", "cell"})
      for (LabelId c : scoredClasses(r.labels)) {
        const ConfusionMatrix& m = level[0] == 'p' ? x.counts.point_wise : x.counts.cell_wise;
        const ClassScores s = m.scores(c);
        o << csvStr(x.dataset) << "," << csvStr(x.optimiser) << "," << csvStr(x.feature_set)
          << ",ok," << level << "," << r.labels.name(c) << "," << s.tp << "," << s.fp << "," << s.fn
          << "," << s.tn << "," << csvNum(s.precision()) << "," << csvNum(s.recall()) << ","
          << csvNum(s.tpr()) << "," << csvNum(s.fpr()) << "," << x.counts.scans << ","
          << x.counts.points << "," << x.counts.labelled_points << "," << x.counts.classified_points
          << "," << x.counts.cells_scored << "\n";
      }
  }
  return o.str();
}

/// Cell-wise precision/recall of every class, one row per scan (paper 001's rules).
std::string perScanCsv(const SweepResult& r) {
  std::ostringstream o;
  o << "dataset,feature_set,optimiser,frame,level,class,tp,fp,fn,precision,recall\n";
  for (const auto& x : r.runs)
    for (const auto& [frame, counts] : x.per_scan)
      for (const char* level : {"point", "cell"})
        for (LabelId c : scoredClasses(r.labels)) {
          const ClassScores s = (level[0] == 'p' ? counts.point_wise : counts.cell_wise).scores(c);
          o << csvStr(x.dataset) << "," << csvStr(x.feature_set) << "," << csvStr(x.optimiser) << ","
            << csvStr(frame) << "," << level << "," << r.labels.name(c) << "," << s.tp << ","
            << s.fp << "," << s.fn << "," << csvNum(s.precision()) << "," << csvNum(s.recall())
            << "\n";
        }
  return o.str();
}

/// Markdown: one row per run and scan, cell-wise P/R per class.
std::string perScanSection(const SweepResult& r) {
  std::ostringstream o;
  o << "## Cell-wise precision / recall per scan (paper 001 §VI-B)\n\n| dataset | feature set | "
       "optimiser | scan |";
  const std::vector<LabelId> classes = scoredClasses(r.labels);
  for (LabelId c : classes) o << " " << r.labels.name(c) << " P / R |";
  o << "\n|---|---|---|---|";
  for (std::size_t i = 0; i < classes.size(); ++i) o << "---:|";
  o << "\n";
  for (const auto& x : r.runs)
    for (const auto& [frame, counts] : x.per_scan) {
      o << "| " << x.dataset << " | " << x.feature_set << " | " << x.optimiser << " | " << frame
        << " |";
      for (LabelId c : classes) {
        const ClassScores s = counts.cell_wise.scores(c);
        o << " " << fmt("%.3f", s.precision()) << " / " << fmt("%.3f", s.recall()) << " |";
      }
      o << "\n";
    }
  return o.str() + "\n";
}

std::string runtimeCsv(const SweepResult& r) {
  std::ostringstream o;
  o << "dataset,feature_set,optimiser,status,scans,processing_mean_ms,processing_std_ms,"
       "processing_max_ms,processing_min_ms,processing_median_ms,features_mean_ms,mrf_mean_ms,"
       "total_mean_ms\n";
  for (const auto& x : r.runs) {
    const Stats p = stats(x.times.processing);
    o << csvStr(x.dataset) << "," << csvStr(x.feature_set) << "," << csvStr(x.optimiser) << ","
      << statusName(x.status) << "," << p.n << "," << csvNum(p.mean) << "," << csvNum(p.stddev)
      << "," << csvNum(p.max) << "," << csvNum(p.min) << "," << csvNum(p.median) << ","
      << csvNum(stats(x.times.features).mean) << "," << csvNum(stats(x.times.mrf).mean) << ","
      << csvNum(stats(x.times.total).mean) << "\n";
  }
  return o.str();
}

std::string energiesCsv(const SweepResult& r) {
  std::ostringstream o;
  o << "dataset,feature_set,optimiser,frame,initial_energy,reported_final_energy,energy,"
       "iterations,converged\n";
  for (const auto& x : r.runs)
    for (const auto& e : x.energies)
      o << csvStr(x.dataset) << "," << csvStr(x.feature_set) << "," << csvStr(x.optimiser) << ","
        << csvStr(e.frame) << "," << csvNum(e.initial) << "," << csvNum(e.reported) << ","
        << csvNum(e.recomputed) << "," << e.iterations << "," << (e.converged ? 1 : 0) << "\n";
  return o.str();
}

std::string rocAucCsv(const SweepResult& r) {
  std::ostringstream o;
  o << "dataset,feature_set,optimiser,class,score_source,positives,negatives,auc,operating_fpr,"
       "operating_tpr\n";
  for (const auto& x : r.runs)
    for (const auto& c : x.roc)
      o << csvStr(x.dataset) << "," << csvStr(x.feature_set) << "," << csvStr(x.optimiser) << ","
        << c.class_name << "," << toString(x.score_source) << "," << c.positives << ","
        << c.negatives << "," << csvNum(c.auc) << "," << csvNum(c.operating_fpr) << ","
        << csvNum(c.operating_tpr) << "\n";
  return o.str();
}

std::string timesJson(const std::vector<double>& v) {
  const Stats s = stats(v);
  std::ostringstream o;
  o << "{\"scans\": " << s.n << ", \"mean\": " << jsonNum(s.mean)
    << ", \"std\": " << jsonNum(s.stddev) << ", \"max\": " << jsonNum(s.max)
    << ", \"min\": " << jsonNum(s.min) << ", \"median\": " << jsonNum(s.median)
    << ", \"per_scan\": [";
  for (std::size_t i = 0; i < v.size(); ++i) o << (i ? ", " : "") << jsonNum(v[i]);
  o << "]}";
  return o.str();
}

std::string resultsJson(const SweepResult& r) {
  auto list = [](const std::vector<std::string>& v) {
    std::string s = "[";
    for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + jsonStr(v[i]);
    return s + "]";
  };
  std::ostringstream o;
  o << "{\n  \"schema\": \"terramrf.compare/1\",\n  \"name\": " << jsonStr(r.name)
    << ",\n  \"sweep\": " << jsonStr(r.sweep_path)
    << ",\n  \"output_dir\": " << jsonStr(r.output_dir) << ",\n  \"created\": " << jsonStr(utcNow())
    << ",\n  \"tool\": " << jsonStr(std::string("terramrf ") + TERRAMRF_VERSION)
    << ",\n  \"limit\": " << r.limit << ",\n  \"labels\": " << list(r.labels.names())
    << ",\n  \"datasets\": " << list(r.datasets)
    << ",\n  \"feature_sets\": " << list(r.feature_sets)
    << ",\n  \"optimisers\": " << list(r.optimisers) << ",\n  \"train\": " << list(r.train_items)
    << ",\n  \"models\": [";
  for (std::size_t i = 0; i < r.models.size(); ++i) {
    const auto& m = r.models[i];
    o << (i ? "," : "") << "\n    {\"feature_set\": " << jsonStr(m.feature_set)
      << ", \"path\": " << (m.path.empty() ? "null" : jsonStr(m.path))
      << ", \"trained\": " << (m.trained ? "true" : "false")
      << ", \"reason\": " << jsonStr(m.reason) << ", \"frames\": " << m.frames
      << ", \"labelled_frames\": " << m.labelled_frames << ", \"train\": " << list(m.train_items)
      << ", \"not_learnt\": " << list(m.missing) << "}";
  }
  o << "\n  ],\n  \"runs\": [";
  for (std::size_t i = 0; i < r.runs.size(); ++i) {
    const auto& x = r.runs[i];
    o << (i ? "," : "") << "\n    {\"dataset\": " << jsonStr(x.dataset)
      << ", \"feature_set\": " << jsonStr(x.feature_set)
      << ", \"optimiser\": " << jsonStr(x.optimiser) << ", \"status\": \"" << statusName(x.status)
      << "\", \"reason\": " << jsonStr(x.reason) << ", \"output_dir\": " << jsonStr(x.output_dir)
      << ", \"frames\": " << x.frames << ", \"frames_ok\": " << x.frames_ok << ", \"failed\": [";
    for (std::size_t k = 0; k < x.failed.size(); ++k)
      o << (k ? ", " : "") << "{\"frame\": " << jsonStr(x.failed[k].first)
        << ", \"reason\": " << jsonStr(x.failed[k].second) << "}";
    o << "],\n     \"times_ms\": {\"processing\": " << timesJson(x.times.processing)
      << ",\n                  \"features\": " << timesJson(x.times.features)
      << ",\n                  \"mrf\": " << timesJson(x.times.mrf)
      << ",\n                  \"total\": " << timesJson(x.times.total)
      << "},\n     \"energies\": [";
    for (std::size_t k = 0; k < x.energies.size(); ++k) {
      const auto& e = x.energies[k];
      o << (k ? ", " : "") << "{\"frame\": " << jsonStr(e.frame)
        << ", \"initial\": " << jsonNum(e.initial) << ", \"reported\": " << jsonNum(e.reported)
        << ", \"energy\": " << jsonNum(e.recomputed) << ", \"iterations\": " << e.iterations
        << ", \"converged\": " << (e.converged ? "true" : "false") << "}";
    }
    o << "],\n     \"roc\": {\"scores\": \"" << (x.roc.empty() ? "none" : toString(x.score_source))
      << "\", \"note\": " << jsonStr(x.roc_note) << ", \"curves\": " << rocSummaryJson(x.roc)
      << "}";
    if (x.status == RunRecord::Status::kOk)
      o << ",\n     \"evaluation\": " << toJson(x.counts, r.labels);
    o << "}";
  }
  o << "\n  ]\n}\n";
  return o.str();
}

}  // namespace

std::string accuracyTable(const SweepResult& r, const std::string& dataset,
                          const std::string& optimiser) {
  std::ostringstream o;
  o << "| Class/value |";
  for (const auto& f : r.feature_sets) o << " " << f << " |";
  o << "\n|---|";
  for (std::size_t i = 0; i < r.feature_sets.size(); ++i) o << "---:|";
  o << "\n";
  for (LabelId c : scoredClasses(r.labels)) {
    for (const char* what : {"TPR", "FPR"}) {
      o << "| " << capitalise(r.labels.name(c)) << "/" << what << " |";
      for (const auto& f : r.feature_sets) {
        const RunRecord* x = r.find(dataset, f, optimiser);
        std::string cell = statusCell(x);
        if (cell.empty()) {
          const ClassScores s = x->counts.cell_wise.scores(c);
          cell = x->counts.scans == 0 ? "not scored" : pct(what[0] == 'T' ? s.tpr() : s.fpr());
        }
        o << " " << cell << " |";
      }
      o << "\n";
    }
  }
  return o.str();
}

std::string runtimeTable(const SweepResult& r, const std::string& dataset) {
  std::ostringstream o;
  const bool many = r.optimisers.size() > 1;
  o << "| Mode | Mean | Std. dev. | Max | Min | scans | features (mean) | MRF (mean) |\n"
       "|---|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const auto& f : r.feature_sets)
    for (const auto& op : r.optimisers) {
      const RunRecord* x = r.find(dataset, f, op);
      o << "| " << f << (many ? " (" + op + ")" : std::string()) << " |";
      const std::string st = statusCell(x);
      if (!st.empty()) {
        o << " " << st << " | | | | | | |\n";
        continue;
      }
      const Stats p = stats(x->times.processing);
      o << " " << fmt("%.1f ms", p.mean) << " | " << fmt("%.1f ms", p.stddev) << " | "
        << fmt("%.1f ms", p.max) << " | " << fmt("%.1f ms", p.min) << " | " << p.n << " | "
        << fmt("%.1f ms", stats(x->times.features).mean) << " | "
        << fmt("%.1f ms", stats(x->times.mrf).mean) << " |\n";
    }
  return o.str();
}

void writeSweepReport(const SweepResult& r, const std::string& dir) {
  fs::create_directories(dir + "/roc");
  std::ostringstream acc, rt;
  acc << "## Accuracy per feature set (cell-wise TPR/FPR, paper 000 Tables 1–2)\n\n";
  for (const auto& ds : r.datasets)
    for (const auto& op : r.optimisers)
      acc << "### " << ds << ", optimiser " << op << "\n\n" << accuracyTable(r, ds, op) << "\n";
  rt << "## Runtime per scan (paper 000 Table 3)\n\n"
        "Processing = grid + feature + energy + optimiser stages (reading and outputs excluded); "
        "features = grid + egomotion + feature stages; MRF = energy + optimiser.\n\n";
  for (const auto& ds : r.datasets) rt << "### " << ds << "\n\n" << runtimeTable(r, ds) << "\n";
  const std::string energies = energiesSection(r), evaluation = evaluationSection(r),
                    roc = rocSection(r), runs = runsSection(r);
  std::ostringstream head;
  head << "# Sweep '" << r.name << "'\n\n- sweep file: " << r.sweep_path
       << "\n- created: " << utcNow() << " (terramrf " << TERRAMRF_VERSION << ")\n- train split:";
  for (const auto& t : r.train_items) head << " " << t << ";";
  head << "\n- test datasets:";
  for (const auto& t : r.datasets) head << " " << t << ";";
  if (r.limit) head << "\n- at most " << r.limit << " frame(s) per split item (--limit)";
  std::size_t skipped = 0, failed = 0;
  for (const auto& x : r.runs) {
    skipped += x.status == RunRecord::Status::kSkipped;
    failed += x.status == RunRecord::Status::kFailed;
  }
  head << "\n- runs: " << r.runs.size() << " (" << skipped << " skipped, " << failed
       << " failed; reasons under Runs)\n\n";
  writeFileAtomic(dir + "/accuracy.md", acc.str());
  writeFileAtomic(dir + "/runtime.md", rt.str());
  writeFileAtomic(dir + "/energies.md", energies);
  const std::string per_scan = perScanSection(r);
  writeFileAtomic(dir + "/evaluation.md", evaluation);
  writeFileAtomic(dir + "/per_scan.md", per_scan);
  writeFileAtomic(dir + "/summary.md", head.str() + acc.str() + per_scan + rt.str() + roc +
                                           energies + runs + evaluation);
  writeFileAtomic(dir + "/accuracy.csv", accuracyCsv(r));
  writeFileAtomic(dir + "/evaluation.csv", evaluationCsv(r));
  writeFileAtomic(dir + "/per_scan.csv", perScanCsv(r));
  writeFileAtomic(dir + "/runtime.csv", runtimeCsv(r));
  writeFileAtomic(dir + "/energies.csv", energiesCsv(r));
  writeFileAtomic(dir + "/roc_auc.csv", rocAucCsv(r));
  writeFileAtomic(dir + "/results.json", resultsJson(r));
  for (const auto& x : r.runs) {
    if (x.roc.empty()) continue;
    const std::string base = dir + "/roc/" + sanitize(x.key());
    writeFileAtomic(base + ".csv", rocCsv(x.roc));
    writeFileAtomic(base + ".svg", rocSvg(x.roc, r.labels,
                                          x.dataset + " — " + x.feature_set + " — " + x.optimiser +
                                              " (" + toString(x.score_source) + ")"));
  }
}

}  // namespace terramrf
