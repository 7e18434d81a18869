// Plugins from `{name, type, params}` snippets of a train config / sweep file, and pipelines
// assembled from them (errors point at that file).
#include "terramrf/sweep.hpp"

#include <algorithm>
#include <filesystem>
#include <set>

#include "config_internal.hpp"
#include "param_yaml.hpp"
#include "sweep_internal.hpp"
#include "terramrf/param_values.hpp"

namespace terramrf {
namespace fs = std::filesystem;

namespace sweep_detail {
namespace {

/// The YAML of a configured plugin as a config entry, every parameter with its value.
YAML::Node resolvedEntry(Plugin& p) {
  YAML::Node n(YAML::NodeType::Map);
  n["name"] = p.name();
  n["type"] = p.type();
  n["params"] = detail::currentParams(p);
  return n;
}

}  // namespace
}  // namespace sweep_detail

namespace sweep_detail {

Made makePlugin(PluginRegistry& reg, const YAML::Node& e, const std::string& section,
                const std::vector<PluginKind>& kinds, const PluginContext& ctx, Diags& d,
                bool tolerate_missing, bool configure) {
  Made m;
  detail::EntryChecks checks;
  checks.key_hint = kKeyHint;
  checks.key_errors_name_the_stage = false;
  detail::EntryPlugin ep = detail::createEntryPlugin(reg, e, section, kinds, d, checks);
  const std::string& name = ep.name;
  const std::string& type = ep.type;
  if (ep.unknown_type) {
    // A sweep may name plugins that are not built: the runs that need them are skipped. A name
    // close to an installed plugin is a typo, though, and skipping it would hide it.
    std::string why = "plugin type '" + type + "' is not installed";
    if (!ep.suggestion.empty()) why += " (did you mean '" + ep.suggestion + "'?)";
    if (tolerate_missing && ep.suggestion.empty()) {
      m.not_installed = why;
    } else {
      d.add(e["type"].Mark(), why + "; run 'terramrf plugins' for the list", name, type);
    }
    return m;
  }
  if (!ep.plugin) return m;
  m.kind = ep.kind;
  std::unique_ptr<Plugin>& p = ep.plugin;
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
  if (detail::applyEntryParams(*p, e, ctx, d)) m.plugin = std::move(p);
  return m;
}

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
  PluginContext ctx = f0.context(p.output_dir);
  // Grows as the stages are made: each sees how the layers before it are computed.
  ctx.layer_origins = &p.layer_origins;
  YAML::Node resolved(YAML::NodeType::Map);
  resolved["version"] = 1;
  resolved["grid"]["size_m"] = f0.grid.size_m;
  resolved["grid"]["cell_m"] = f0.grid.cell_m;
  if (f0.custom_labels) resolved["labels"] = f0.labels_node;
  for (const auto& dir : f0.plugin_dirs) resolved["plugin_path"].push_back(dir);
  resolved["source"] = resolvedEntry(*item.src);
  std::set<std::string> names = {item.src->name()};
  // The same order and read/write check as a run config's.
  detail::StageFlow flow(d);
  flow.source(*item.src, item.source.Mark().is_null() ? item.mark : item.source.Mark());
  detail::recordSourceOrigins(*item.src, p.layer_origins);
  for (const auto& e : stage_entries) {
    Made m = makePlugin(
        reg, e, "stages",
        {PluginKind::kEgomotion, PluginKind::kFeature, PluginKind::kEnergy, PluginKind::kOptimiser},
        ctx, d, false);
    if (!m.ok()) {
      flow.entryFailed();
      continue;
    }
    if (!names.insert(m.plugin->name()).second)
      d.add(e.Mark(), "duplicate stage name '" + m.plugin->name() + "' (give each a unique name:)",
            m.plugin->name(), m.plugin->type());
    flow.stage(*m.plugin, m.kind, e.Mark());
    detail::recordLayerOrigins(*m.plugin, f0.grid.cell_m, p.layer_origins);
    resolved["stages"].push_back(resolvedEntry(*m.plugin));
    p.stage_kinds.push_back(m.kind);
    p.stages.emplace_back(static_cast<Stage*>(m.plugin.release()));
  }
  for (const auto& e : output_entries) {
    Made m = makePlugin(reg, e, "outputs", {PluginKind::kOutput}, ctx, d, false);
    if (!m.ok()) continue;
    flow.output(*m.plugin, e.Mark());
    resolved["outputs"].push_back(resolvedEntry(*m.plugin));
    p.outputs.emplace_back(static_cast<Output*>(m.plugin.release()));
  }
  for (auto& o : extra_outputs) {
    flow.output(*o, YAML::Mark::null_mark());
    p.outputs.push_back(std::move(o));
  }
  d.throwIfAny();
  YAML::Emitter em;
  em << resolved;
  p.resolved_yaml = "# Generated from " + f0.file + " (source '" + item.label +
                    "'); runnable with 'terramrf run'.\n" + em.c_str() + "\n";
  return p;
}

RunOptions runOptions(const Item& it, std::ostream* log, bool timed) {
  RunOptions ro;
  ro.progress = false;
  ro.log = log;
  ro.first = it.first;
  ro.limit = it.count;
  if (timed) ro.read_ahead = 0;
  return ro;
}

std::vector<std::string> pluginDirs(const std::vector<std::string>& given) {
  return given.empty() ? PluginRegistry::defaultSearchDirs() : given;
}

}  // namespace sweep_detail

}  // namespace terramrf
