// Reading sweep files and what train configs share with them: diagnostics with file positions,
// grid/labels/plugin_path, the version; loadSweep validates a whole sweep before anything runs.
#include "terramrf/sweep.hpp"

#include <filesystem>
#include <set>
#include <sstream>

#include "config_internal.hpp"
#include "param_yaml.hpp"
#include "sweep_internal.hpp"
#include "terramrf/param_values.hpp"

namespace terramrf {
namespace fs = std::filesystem;

namespace sweep_detail {
namespace {

const std::vector<std::string> kSweepKeys = {
    "version",    "name",     "grid",     "labels",        "plugin_path",
    "output_dir", "datasets", "split",    "common_stages", "feature_sets",
    "optimisers", "energy",   "training", "outputs",       "roc"};

/// What a sweep's `training:` may set: the parameters feature_stats declares, except those compare
/// sets per feature set (its features and the model file). Empty if feature_stats is not installed
/// (no model can be trained then; the runs that need one say so).
std::vector<std::string> trainingKeys(PluginRegistry& reg) {
  std::vector<std::string> keys;
  if (!reg.find(kStatsPlugin)) return keys;
  try {
    const auto stats = reg.create(kStatsPlugin);
    for (const auto& spec : declaredParams(*stats))
      if (spec.name != "features" && spec.name != "model") keys.push_back(spec.name);
  } catch (const std::exception&) {
    // Reported when training needs it.
  }
  return keys;
}

}  // namespace
}  // namespace sweep_detail

namespace sweep_detail {

std::string absPath(const std::string& base_dir, const std::string& p) {
  fs::path q(p);
  if (!q.is_absolute()) q = fs::path(base_dir) / q;
  return q.lexically_normal().string();
}

void readFrame0(const YAML::Node& root, Frame0& f0, Diags& d, PluginRegistry& reg) {
  detail::CommonKeys common = detail::readCommonKeys(root, f0.base_dir, reg, d, kKeyHint);
  f0.grid = common.grid;
  f0.labels = common.labels;
  f0.custom_labels = common.custom_labels;
  if (common.custom_labels) f0.labels_node = root["labels"];
  f0.plugin_dirs = common.plugin_dirs;
}

std::vector<std::string> stringList(const YAML::Node& n) {
  std::vector<std::string> v;
  if (!n) return v;
  if (n.IsScalar()) v.push_back(n.Scalar());
  if (n.IsSequence())
    for (const auto& e : n) v.push_back(e.Scalar());
  return v;
}

std::unique_ptr<Sweep> loadSweep(const std::string& path, PluginRegistry& reg,
                                 const std::string& output_dir, std::size_t limit) {
  auto s = std::make_unique<Sweep>();
  s->file = path;
  Diags d;
  d.file = path;
  const YAML::Node root = detail::loadYamlFile(path, d, "file");
  if (!root.IsMap()) {
    d.add(root.Mark(),
          "expected a sweep (a map with version, datasets, split, feature_sets, "
          "optimisers)");
    d.throwIfAny();
  }
  detail::checkKeys(d, root, kSweepKeys, "the sweep", kKeyHint);
  detail::checkVersion(root, d);
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
      detail::checkKeys(d, it->second, detail::kEntryKeys, "dataset '" + it->first.Scalar() + "'", kKeyHint);
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
      detail::checkKeys(d, v, {"extends", "stages", "features", "min_sigma", "model", "train"}, what, kKeyHint);
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
      const std::vector<std::string> keys = trainingKeys(reg);
      if (!keys.empty()) detail::checkKeys(d, tr, keys, "training", kKeyHint);
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
      detail::checkKeys(d, roc, {"max_points", "fallback"}, "roc", kKeyHint);
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

}  // namespace sweep_detail

}  // namespace terramrf
