#include "terramrf/config.hpp"

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <set>
#include <sstream>

#include "param_yaml.hpp"

namespace terramrf {
namespace fs = std::filesystem;

std::string Diagnostic::str() const {
  std::ostringstream o;
  o << file;
  if (line > 0) o << ":" << line << ":" << column;
  o << ": ";
  if (!stage.empty() || !type.empty()) {
    o << "stage '" << stage << "'";
    if (!type.empty()) o << " (" << type << ")";
    o << ": ";
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

namespace {

struct Collector {
  std::string file;
  std::vector<Diagnostic> diags;
  void add(const YAML::Mark& m, const std::string& stage, const std::string& type,
           const std::string& msg) {
    Diagnostic d;
    d.file = file;
    if (m.line >= 0 && m.pos >= 0) {
      d.line = m.line + 1;
      d.column = m.column + 1;
    }
    d.stage = stage;
    d.type = type;
    d.message = msg;
    diags.push_back(std::move(d));
  }
};

const std::vector<std::string> kTopKeys = {"version", "plugin_path", "grid", "labels", "split",
                                           "source", "stages", "outputs", "output_dir"};
const std::vector<std::string> kStageKeys = {"name", "type", "params"};

void checkKeys(Collector& c, const YAML::Node& map, const std::vector<std::string>& allowed,
               const std::string& what, const std::string& stage = "",
               const std::string& type = "") {
  for (auto it = map.begin(); it != map.end(); ++it) {
    const std::string k = it->first.as<std::string>();
    if (std::find(allowed.begin(), allowed.end(), k) != allowed.end()) continue;
    std::string m = "unknown key '" + k + "' in " + what;
    const std::string dym = detail::didYouMean(k, allowed);
    if (!dym.empty()) m += " (did you mean '" + dym + "'?)";
    c.add(it->first.Mark(), stage, type, m);
  }
}

bool isStageKind(PluginKind k) {
  return k == PluginKind::kEgomotion || k == PluginKind::kFeature || k == PluginKind::kEnergy ||
         k == PluginKind::kOptimiser;
}

std::string kindList(const std::vector<PluginKind>& ks) {
  std::string s;
  for (auto k : ks) s += (s.empty() ? "" : "/") + std::string(toString(k));
  return s;
}

}  // namespace

Pipeline loadPipeline(const std::string& config_path, const LoadOptions& options,
                      PluginRegistry& registry) {
  Collector c;
  c.file = config_path;
  YAML::Node root;
  try {
    if (!fs::exists(config_path)) {
      c.add(YAML::Mark::null_mark(), "", "", "config file does not exist");
      throw ConfigError(c.diags);
    }
    root = YAML::LoadFile(config_path);
  } catch (const YAML::Exception& e) {
    c.add(e.mark, "", "", "YAML syntax error: " + e.msg);
    throw ConfigError(c.diags);
  }
  if (!root.IsMap()) {
    c.add(root.Mark(), "", "", "expected a map with keys version, grid, source, stages, outputs");
    throw ConfigError(c.diags);
  }
  checkKeys(c, root, kTopKeys, "the config");

  Pipeline p;
  p.config_path = config_path;
  const std::string config_dir = fs::absolute(config_path).parent_path().string();

  // version
  if (!root["version"]) {
    c.add(root.Mark(), "", "", "missing key 'version' (expected 'version: 1')");
  } else if (root["version"].Scalar() != "1") {
    c.add(root["version"].Mark(), "", "", "unsupported version '" + root["version"].Scalar() +
                                            "' (this build reads version 1)");
  }

  // plugin_path
  if (const auto pp = root["plugin_path"]) {
    std::vector<std::string> dirs;
    if (!pp.IsSequence()) {
      c.add(pp.Mark(), "", "", "'plugin_path' must be a list of folders");
    } else {
      for (const auto& d : pp) {
        const std::string dir = (fs::path(config_dir) / d.Scalar()).lexically_normal().string();
        if (!fs::is_directory(dir))
          c.add(d.Mark(), "", "", "plugin_path entry '" + dir + "' is not a folder");
        dirs.push_back(dir);
      }
    }
    if (!dirs.empty()) registry.prependDirs(dirs);
  }

  // grid
  if (const auto g = root["grid"]) {
    if (!g.IsMap()) {
      c.add(g.Mark(), "", "", "'grid' must be a map {size_m, cell_m}");
    } else {
      checkKeys(c, g, {"size_m", "cell_m"}, "grid");
      auto num = [&](const char* key, double lo, double hi, double& out) {
        if (!g[key]) return;
        try {
          const double v = g[key].as<double>();
          if (v < lo || v > hi) {
            std::ostringstream o;
            o << "grid." << key << " = " << v << " out of range: expected [" << lo << ", " << hi
              << "] m";
            c.add(g[key].Mark(), "", "", o.str());
          } else {
            out = v;
          }
        } catch (const YAML::Exception&) {
          c.add(g[key].Mark(), "", "", std::string("grid.") + key + ": expected a number in metres");
        }
      };
      num("size_m", 20, 100, p.grid.size_m);
      num("cell_m", 0.05, 5, p.grid.cell_m);
    }
  }

  // labels (optional): list of {name, color: [r,g,b]} starting with unknown
  p.labels = std::make_shared<LabelSet>(LabelSet::defaults());
  if (const auto l = root["labels"]) {
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
      p.labels = std::make_shared<LabelSet>(infos);
    } catch (const std::exception& e) {
      c.add(l.Mark(), "", "",
            std::string("labels: expected a list of {name, color: [r, g, b]} starting with "
                        "'unknown': ") + e.what());
    }
  }

  // output dir
  p.output_dir = options.output_dir;
  if (p.output_dir.empty()) {
    p.output_dir = root["output_dir"] ? (fs::path(config_dir) / root["output_dir"].Scalar()).string()
                                      : (fs::current_path() / "out").string();
  }
  p.output_dir = fs::absolute(p.output_dir).lexically_normal().string();

  PluginContext ctx;
  ctx.config_dir = config_dir;
  ctx.output_dir = p.output_dir;
  ctx.grid = p.grid;
  ctx.labels = p.labels.get();

  YAML::Node resolved = YAML::Clone(root);
  resolved["grid"]["size_m"] = p.grid.size_m;
  resolved["grid"]["cell_m"] = p.grid.cell_m;

  // Instantiates one plugin entry; returns nullptr after recording diagnostics.
  std::set<std::string> names;
  auto make = [&](const YAML::Node& e, const std::string& section,
                  const std::vector<PluginKind>& kinds, PluginKind* kind_out,
                  const std::vector<std::pair<std::string, std::string>>& overrides,
                  YAML::Node resolved_entry) -> std::unique_ptr<Plugin> {
    if (!e.IsMap()) {
      c.add(e.Mark(), "", "", section + " entries must be maps {name, type, params}");
      return nullptr;
    }
    checkKeys(c, e, kStageKeys, section + " entry", e["name"] ? e["name"].Scalar() : "",
              e["type"] ? e["type"].Scalar() : "");
    if (!e["type"]) {
      c.add(e.Mark(), e["name"] ? e["name"].Scalar() : "", "",
            "missing key 'type' (the plugin type name)");
      return nullptr;
    }
    const std::string type = e["type"].Scalar();
    const std::string name = e["name"] ? e["name"].Scalar() : type;
    if (!names.insert(name).second)
      c.add(e.Mark(), name, type, "duplicate stage name '" + name + "' (give each a unique name:)");
    const PluginInfo* info = registry.find(type);
    if (!info) {
      std::string m = "unknown plugin type '" + type + "'";
      const std::string dym = detail::didYouMean(type, registry.types());
      if (!dym.empty()) m += " (did you mean '" + dym + "'?)";
      m += "; run 'terramrf plugins' for the list";
      c.add(e["type"].Mark(), name, type, m);
      return nullptr;
    }
    if (std::find(kinds.begin(), kinds.end(), info->kind) == kinds.end()) {
      c.add(e["type"].Mark(), name, type,
            "'" + type + "' is a " + toString(info->kind) + " plugin, but " + section +
                " takes " + kindList(kinds) + " plugins");
      return nullptr;
    }
    std::unique_ptr<Plugin> plugin;
    try {
      plugin = registry.create(type);
    } catch (const std::exception& ex) {
      c.add(e["type"].Mark(), name, type, ex.what());
      return nullptr;
    }
    plugin->setIdentity(name, type);
    if (kind_out) *kind_out = info->kind;
    const auto issues = detail::applyParams(*plugin, e["params"], ctx, e.Mark(), overrides);
    for (const auto& i : issues) c.add(i.mark, name, type, i.message);
    if (!issues.empty()) return nullptr;
    resolved_entry["name"] = name;
    resolved_entry["params"] = detail::currentParams(*plugin);
    return plugin;
  };

  // source
  if (!root["source"]) {
    c.add(root.Mark(), "", "", "missing key 'source' (where frames come from, e.g. {type: simulator})");
  } else {
    std::vector<std::pair<std::string, std::string>> ov;
    if (!options.data_override.empty())
      ov.push_back({"path", fs::absolute(options.data_override).lexically_normal().string()});
    auto pl = make(root["source"], "source", {PluginKind::kSource}, nullptr, ov, resolved["source"]);
    if (pl) p.source.reset(static_cast<Source*>(pl.release()));
  }

  // stages + the read/write check
  std::set<std::string> available = {artefacts::kPoints};
  std::vector<std::string> available_order = {artefacts::kPoints};
  auto checkReads = [&](Plugin& pl, const YAML::Node& e) {
    for (const auto& r : pl.reads()) {
      if (available.count(r)) continue;
      std::string have;
      for (const auto& a : available_order) have += (have.empty() ? "" : ", ") + a;
      c.add(e.Mark(), pl.name(), pl.type(),
            "reads '" + r + "', which no earlier stage writes (available here: " + have + ")");
    }
  };
  auto addWrites = [&](Plugin& pl) {
    for (const auto& w : pl.writes())
      if (available.insert(w).second) available_order.push_back(w);
  };
  if (const auto st = root["stages"]) {
    if (!st.IsSequence()) {
      c.add(st.Mark(), "", "", "'stages' must be a list");
    } else {
      bool seen_non_ego = false;
      for (std::size_t i = 0; i < st.size(); ++i) {
        PluginKind kind = PluginKind::kFeature;
        auto pl = make(st[i], "stages",
                       {PluginKind::kEgomotion, PluginKind::kFeature, PluginKind::kEnergy,
                        PluginKind::kOptimiser},
                       &kind, {}, resolved["stages"][i]);
        if (!pl) continue;
        if (kind == PluginKind::kEgomotion && seen_non_ego)
          c.add(st[i].Mark(), pl->name(), pl->type(),
                "egomotion stages must come before feature/energy/optimiser stages (the grid is "
                "built after the pose is known)");
        if (kind != PluginKind::kEgomotion) seen_non_ego = true;
        checkReads(*pl, st[i]);
        addWrites(*pl);
        p.stage_kinds.push_back(kind);
        p.stages.emplace_back(static_cast<Stage*>(pl.release()));
      }
    }
  } else {
    c.add(root.Mark(), "", "", "missing key 'stages' (features, energy, optimiser)");
  }

  if (const auto out = root["outputs"]) {
    if (!out.IsSequence()) {
      c.add(out.Mark(), "", "", "'outputs' must be a list");
    } else {
      for (std::size_t i = 0; i < out.size(); ++i) {
        auto pl = make(out[i], "outputs", {PluginKind::kOutput}, nullptr, {}, resolved["outputs"][i]);
        if (!pl) continue;
        checkReads(*pl, out[i]);
        p.outputs.emplace_back(static_cast<Output*>(pl.release()));
      }
    }
  }

  if (!c.diags.empty()) throw ConfigError(c.diags);
  YAML::Emitter em;
  em << resolved;
  p.resolved_yaml = std::string("# Resolved config: every parameter with its value (defaults filled "
                                "in) from ") + config_path + "\n" + em.c_str() + "\n";
  return p;
}

}  // namespace terramrf
