// Reading sweep files and what train configs share with them: diagnostics with file positions,
// grid/labels/plugin_path, the version; loadSweep validates a whole sweep before anything runs.
#include <algorithm>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>

#include "config_internal.hpp"
#include "param_yaml.hpp"
#include "sweep_internal.hpp"
#include "terramrf/param_values.hpp"
#include "terramrf/roc.hpp"
#include "terramrf/sweep.hpp"
#include "terramrf/text_format.hpp"

namespace terramrf {
namespace fs = std::filesystem;

namespace sweep_detail {
namespace {

const std::vector<std::string> kSweepKeys = {
    "version",  "name",   "grid",          "labels",       "plugin_path",   "output_dir",
    "datasets", "split",  "common_stages", "feature_sets", "optimisers",    "energy",
    "training", "select", "outputs",       "roc",          "frame_cache_mb"};

/// Candidates `select:` may list before the product is refused (each costs a training and
/// validation runs per feature set).
constexpr std::size_t kMaxCandidates = 64;

/// The grid layers source `s` brings made (its writes() but frame artefacts such as '@pose').
std::vector<std::string> broughtLayers(const Source& s) {
  std::vector<std::string> b;
  for (const auto& w : s.writes())
    if (w[0] != '@') b.push_back(w);
  return b;
}

/// How a feature set's stages and features are checked (checkSetFlow).
enum class SetFlowCheck {
  kNoSource,  ///< while the sweep is read: only what no source can bring (`@energy`, …)
  kItem,      ///< against the source of one item the set runs on
};

/// The order of feature set `f`'s stages and where its features come from, as a run of it on
/// `item` checks them (kItem): the item's source may bring grid layers made elsewhere (an LCM log
/// with `grid_layers`), the common stages and the set's stages write the rest. With
/// `name_item` (the set's items differ in what their sources bring) each problem says which
/// item's runs it is in. Frame artefacts (`@pose`) are left to each run's check: a run over a
/// source without poses fails, the others run. Problems of the stage entries themselves are
/// reported where they are made, and problems already reported are not repeated.
void checkSetFlow(const Sweep& s, const FeatureSet& f, SetFlowCheck how, const Item* item,
                  bool name_item, PluginRegistry& reg, const PluginContext& ctx, Diags& d) {
  const std::vector<PluginKind> stage_kinds = {PluginKind::kEgomotion, PluginKind::kFeature};
  Diags quiet;
  quiet.file = d.file;
  std::set<std::string> written;
  std::vector<std::pair<Made, YAML::Mark>> made;
  for (const auto* list : {&s.common_stages, &f.stages})
    for (const auto& e : *list) {
      Made m = makePlugin(reg, e, "stages", stage_kinds, ctx, quiet, true);
      if (!m.ok()) return;  // reported where the entry is read
      for (const auto& w : m.plugin->writes()) written.insert(w);
      made.emplace_back(std::move(m), e.Mark());
    }
  if (!quiet.list.empty()) return;
  const Source* src = how == SetFlowCheck::kItem ? item->src.get() : nullptr;
  const std::vector<std::string> brought = src ? broughtLayers(*src) : std::vector<std::string>{};
  const std::string in_runs =
      name_item && src ? " (in the runs on " + item->described() + ", whose source brings " +
                             (brought.empty() ? "no layers" : joinNames(brought)) + ")"
                       : "";
  Diags local;
  local.file = d.file;
  detail::StageFlow flow(local);
  if (src) flow.sourceLayers(*src);
  if (how == SetFlowCheck::kNoSource) flow.sourceFailed();
  for (const auto& [m, mark] : made) flow.stage(*m.plugin, m.kind, mark);
  for (Diagnostic& x : local.list) x.message += in_runs;
  if (how != SetFlowCheck::kNoSource) {
    const std::string what = "feature set '" + f.name + "'";
    for (const auto& feat : f.features) {
      if (written.count(feat) || std::count(brought.begin(), brought.end(), feat)) continue;
      std::vector<std::string> have;
      for (const auto& w : written)
        if (w[0] != '@') have.push_back(w);
      std::string msg =
          what + ": feature '" + feat + "' is not written by any of its or the common stages";
      if (!brought.empty())
        msg += " nor brought by the source of " + item->described() +
               " (brought: " + joinNames(brought) + ")";
      msg += " (written: " + joinNames(have) + ")";
      local.add(f.features_mark, brought.empty() ? msg + in_runs : msg);
    }
  }
  // Said already: at load (without a source), or for another set sharing the common stages.
  for (Diagnostic& x : local.list) {
    const auto same = [&](const Diagnostic& y) {
      return y.line == x.line && y.column == x.column && y.stage == x.stage && y.type == x.type &&
             (y.message == x.message || y.message + in_runs == x.message);
    };
    if (!std::any_of(d.list.begin(), d.list.end(), same)) d.list.push_back(std::move(x));
  }
}

/// The parameters of plugin `type` a sweep may set (`training:` for feature_stats, `energy:` and
/// `select:`): those it declares, except the ones compare sets per feature set (`features`, and
/// the `model` file). Empty if the type is not installed (the runs that need it say so).
std::vector<std::string> settableKeys(PluginRegistry& reg, const std::string& type) {
  std::vector<std::string> keys;
  if (type.empty() || !reg.find(type)) return keys;
  try {
    const auto p = reg.create(type);
    for (const auto& spec : declaredParams(*p))
      if (spec.name != "features" && spec.name != "model") keys.push_back(spec.name);
  } catch (const std::exception&) {
    // Reported where the plugin is made.
  }
  return keys;
}

/// What is wrong with `value` as parameter `key` of plugin `type` (its declared type, range and
/// choices), or "" if it is fine or cannot be checked (type not installed: reported elsewhere).
std::string declaredValueError(PluginRegistry& reg, const std::string& type, const std::string& key,
                               const YAML::Node& value) {
  if (type.empty() || !reg.find(type)) return "";
  std::unique_ptr<Plugin> p;
  try {
    p = reg.create(type);
  } catch (const std::exception&) {
    return "";  // reported where the plugin is made
  }
  ParamDecl decl;
  p->declare(decl);
  const ParamSpec* spec = decl.find(key);
  return spec ? detail::checkParamValue(*spec, value) : "";
}

/// Every declared parameter set in `params` checked now, at its value: the plugin itself is only
/// configured when a run starts (the energy needs the model that training writes), and a bad
/// value must not surface after every model has been trained.
void checkDeclaredValues(PluginRegistry& reg, const std::string& type, const YAML::Node& params,
                         const std::string& what, Diags& d) {
  if (!params || !params.IsMap()) return;
  for (auto it = params.begin(); it != params.end(); ++it) {
    const std::string err = declaredValueError(reg, type, it->first.Scalar(), it->second);
    if (!err.empty()) d.add(it->second.Mark(), what + "." + it->first.Scalar() + ": " + err);
  }
}

/// `select:` — candidate values of training (feature_stats) and energy parameters, scored on
/// split.validation. Every problem is a diagnostic at its place in the sweep.
void parseSelect(const YAML::Node& sel, Sweep& s, PluginRegistry& reg, Diags& d) {
  if (!sel.IsMap()) {
    d.add(sel.Mark(),
          "'select' must be a map {training: {param: [values]}, energy: {param: "
          "[values]}, stages: {stage: {param: [values]}}, optimiser, score}");
    return;
  }
  detail::checkKeys(d, sel, {"training", "energy", "stages", "optimiser", "score", "tie", "refit"},
                    "select", kKeyHint);
  struct Axis {
    bool energy;
    std::string key;
    std::vector<YAML::Node> values;
    std::string stage;  ///< a stage parameter's stage name ("" = training or energy)
    std::string type;   ///< that stage's plugin type
  };
  std::vector<Axis> axes;
  const std::size_t before = d.list.size();
  auto section = [&](const char* name, bool energy) {
    const YAML::Node m = sel[name];
    if (!m) return;
    const std::string what = std::string("select.") + name;
    if (!m.IsMap() || m.size() == 0) {
      d.add(m.Mark(), what + ": expected a map parameter: [candidate values]");
      return;
    }
    // Allowed: what the plugin declares, except what compare sets per feature set.
    const std::vector<std::string> allowed =
        settableKeys(reg, energy ? s.energy["type"].Scalar() : std::string(kStatsPlugin));
    const YAML::Node base = energy ? s.energy["params"] : s.training;
    if (!allowed.empty()) detail::checkKeys(d, m, allowed, what, kKeyHint);
    for (auto it = m.begin(); it != m.end(); ++it) {
      const std::string key = it->first.Scalar();
      if (!allowed.empty() && std::find(allowed.begin(), allowed.end(), key) == allowed.end())
        continue;  // reported above
      if (base && base.IsMap() && base[key])
        d.add(it->first.Mark(), what + "." + key + ": also set in '" +
                                    (energy ? "energy.params" : "training") +
                                    "'; give it in one place (select's values replace it)");
      if (energy)
        for (const auto& f : s.feature_sets)
          if (f.energy[key])
            d.add(it->first.Mark(), what + "." + key + ": also set in feature set '" + f.name +
                                        "' energy; give it in one place");
      // A feature set's own floors would be replaced by the candidates' without a word.
      if (!energy && key == "min_sigma")
        for (const auto& f : s.feature_sets)
          if (f.min_sigma)
            d.add(it->first.Mark(), what + ".min_sigma: also set in feature set '" + f.name +
                                        "' (min_sigma); give it in one place");
      if (!it->second.IsSequence() || it->second.size() == 0) {
        d.add(it->second.Mark(),
              what + "." + key + ": expected a non-empty list of candidate values, e.g. [1, 2]");
        continue;
      }
      Axis a{energy, key, {}};
      // Through a copy: it->second lives in a proxy that dies with the expression naming it,
      // and a range-for over it would walk a destroyed object.
      const YAML::Node values = it->second;
      for (const auto& v : values) a.values.push_back(v);
      axes.push_back(std::move(a));
    }
  };
  section("training", false);
  section("energy", true);
  // Stage parameters: a stage is named as in the feature sets (each set that has a stage of that
  // name gets the values; the others are selected without it).
  if (const YAML::Node st = sel["stages"]) {
    if (!st.IsMap() || st.size() == 0) {
      d.add(st.Mark(), "select.stages: expected a map stage name: {param: [candidate values]}");
    } else {
      std::vector<std::string> stage_names;
      for (const auto& f : s.feature_sets)
        for (const YAML::Node& e : f.stages)
          if (e["name"] &&
              std::find(stage_names.begin(), stage_names.end(), e["name"].Scalar()) ==
                  stage_names.end())
            stage_names.push_back(e["name"].Scalar());
      for (auto it = st.begin(); it != st.end(); ++it) {
        const std::string stage = it->first.Scalar();
        const std::string what = "select.stages." + stage;
        bool common = false;
        for (const YAML::Node& e : s.common_stages)
          common = common || (e["name"] && e["name"].Scalar() == stage);
        // The stage's type, the same in every feature set that has it.
        std::string type, first_set;
        bool clash = false;
        for (const auto& f : s.feature_sets)
          for (const YAML::Node& e : f.stages) {
            if (!e["name"] || e["name"].Scalar() != stage || !e["type"]) continue;
            if (type.empty()) {
              type = e["type"].Scalar();
              first_set = f.name;
            } else if (e["type"].Scalar() != type && !clash) {
              clash = true;
              d.add(it->first.Mark(), what + ": stage '" + stage + "' is a " + type +
                                          " in feature set '" + first_set + "' and a " +
                                          e["type"].Scalar() + " in '" + f.name +
                                          "'; candidate values need one type");
            }
          }
        if (type.empty()) {
          std::string m = what + ": no feature set has a stage named '" + stage + "'";
          if (common)
            m += " (it is a common stage; move it into the feature sets to select its "
                 "parameters)";
          const std::string dym = common ? "" : detail::didYouMean(stage, stage_names);
          m += dym.empty() ? "" : " (did you mean '" + dym + "'?)";
          d.add(it->first.Mark(), m);
          continue;
        }
        if (clash) continue;
        if (!it->second.IsMap() || it->second.size() == 0) {
          d.add(it->second.Mark(), what + ": expected a map parameter: [candidate values]");
          continue;
        }
        const std::vector<std::string> allowed = settableKeys(reg, type);
        if (!allowed.empty()) detail::checkKeys(d, it->second, allowed, what, kKeyHint);
        for (auto p = it->second.begin(); p != it->second.end(); ++p) {
          const std::string key = p->first.Scalar();
          if (!allowed.empty() && std::find(allowed.begin(), allowed.end(), key) == allowed.end())
            continue;  // reported above
          bool reported = false;  // once: feature sets that extend another share its stages
          for (const auto& f : s.feature_sets)
            for (const YAML::Node& e : f.stages)
              if (!reported && e["name"] && e["name"].Scalar() == stage && e["params"] &&
                  e["params"].IsMap() && e["params"][key]) {
                reported = true;
                d.add(p->first.Mark(), what + "." + key + ": also set in feature set '" + f.name +
                                           "' (line " +
                                           std::to_string(e["params"][key].Mark().line + 1) +
                                           "); give it in one place (select's values replace it)");
              }
          if (!p->second.IsSequence() || p->second.size() == 0) {
            d.add(p->second.Mark(), what + "." + key +
                                        ": expected a non-empty list of candidate values, e.g. "
                                        "[1, 2]");
            continue;
          }
          Axis a{false, key, {}, stage, type};
          const YAML::Node values = p->second;  // a copy, as in section() above
          for (const auto& v : values) a.values.push_back(v);
          axes.push_back(std::move(a));
        }
      }
    }
  }
  if (axes.empty()) {
    if (d.list.size() == before)
      d.add(sel.Mark(),
            "select: list candidate values under 'training' (feature_stats "
            "parameters), 'energy' (energy parameters) or 'stages' (parameters of a feature "
            "set's stage)");
    return;
  }
  std::size_t n = 1;
  for (const auto& a : axes) n = std::min(kMaxCandidates + 1, n * a.values.size());
  if (n > kMaxCandidates) {
    d.add(sel.Mark(),
          "select: the listed values make more than " + std::to_string(kMaxCandidates) +
              " candidates (each is trained and validated per feature set); list fewer");
    return;
  }
  // Every value as the plugin would take it (type, range, choices), reported at the value.
  for (const auto& a : axes) {
    const std::string type = !a.stage.empty() ? a.type
                             : a.energy       ? s.energy["type"].Scalar()
                                              : std::string(kStatsPlugin);
    const std::string what = !a.stage.empty() ? "select.stages." + a.stage + "."
                             : a.energy       ? "select.energy."
                                              : "select.training.";
    for (const auto& v : a.values) {
      const std::string err = declaredValueError(reg, type, a.key, v);
      if (!err.empty()) d.add(v.Mark(), what + a.key + ": candidate " + flowText(v) + ": " + err);
    }
  }
  // The product, first axis outermost: candidates come in the order the values are listed.
  std::vector<std::size_t> idx(axes.size(), 0);
  for (std::size_t c = 0; c < n; ++c) {
    Candidate cand;
    for (std::size_t k = 0; k < axes.size(); ++k) {
      const Axis& a = axes[k];
      const YAML::Node& v = a.values[idx[k]];
      if (!a.stage.empty()) {
        cand.stages_text += (cand.stages_text.empty() ? "" : ", ") + a.stage + "." + a.key + "=" +
                            flowText(v);
        cand.stages[a.stage][a.key] = YAML::Clone(v);
        continue;
      }
      std::string& text = a.energy ? cand.energy_text : cand.training_text;
      text += (text.empty() ? "" : ", ") + a.key + "=" + flowText(v);
      (a.energy ? cand.energy : cand.training)[a.key] = YAML::Clone(v);
    }
    s.select.candidates.push_back(std::move(cand));
    for (std::size_t k = axes.size(); k-- > 0;) {
      if (++idx[k] < axes[k].values.size()) break;
      idx[k] = 0;
    }
  }
  // Which optimiser scores them, and how.
  if (const YAML::Node o = sel["optimiser"]) {
    s.select.optimiser = o.Scalar();
    std::vector<std::string> names;
    for (const auto& od : s.optimisers) names.push_back(od.name);
    if (std::find(names.begin(), names.end(), s.select.optimiser) == names.end()) {
      std::string m =
          "select.optimiser: '" + s.select.optimiser + "' is not one of the sweep's optimisers";
      const std::string dym = detail::didYouMean(s.select.optimiser, names);
      m += dym.empty() ? "" : " (did you mean '" + dym + "'?)";
      d.add(o.Mark(), m);
    }
  } else if (!s.optimisers.empty()) {
    s.select.optimiser = s.optimisers.front().name;
  }
  for (const auto& od : s.optimisers)
    if (od.name == s.select.optimiser && !od.unavailable.empty())
      d.add(sel["optimiser"] ? sel["optimiser"].Mark() : sel.Mark(),
            "select: optimiser '" + od.name + "', which scores the candidates, is not installed (" +
                od.unavailable + ")");
  if (const YAML::Node refit = sel["refit"]) {
    try {
      s.select.refit = refit.as<bool>();
    } catch (const YAML::Exception&) {
      d.add(refit.Mark(), "select.refit: expected true or false, got '" + refit.Scalar() + "'");
    }
  }
  if (const YAML::Node tie = sel["tie"]) {
    try {
      s.select.tie = tie.as<double>();
      if (!(s.select.tie >= 0 && s.select.tie < 1)) throw YAML::Exception(tie.Mark(), "");
    } catch (const YAML::Exception&) {
      d.add(tie.Mark(), "select.tie: expected a score difference in [0, 1), e.g. 0.001");
    }
  }
  if (const YAML::Node sc = sel["score"]) {
    s.select.score = sc.Scalar();
    const std::string& v = s.select.score;
    const bool class_f1 = v.rfind("f1_", 0) == 0 && s.f0.labels->find(v.substr(3)) > 0;
    if (v != "macro_f1" && !class_f1) {
      std::string classes;
      for (std::size_t c = 1; c < s.f0.labels->size(); ++c)
        classes += std::string(classes.empty() ? "" : ", ") + "f1_" +
                   s.f0.labels->name(static_cast<LabelId>(c));
      d.add(sc.Mark(), "select.score: '" + v +
                           "'; expected macro_f1 (cell-wise F1 averaged over "
                           "the classes) or the F1 of one class: " +
                           classes);
    }
  }
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
  detail::requireTopLevelMap(
      root, d, "expected a sweep (a map with version, datasets, split, feature_sets, optimisers)");
  detail::refuseOtherKind(root, detail::FileKind::kSweep, d);
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
    // split.train may be left out when every feature set brings its model or its own train list.
    bool train_optional = false;
    if (const YAML::Node fsn = root["feature_sets"]; fsn && fsn.IsMap() && fsn.size() > 0) {
      train_optional = true;
      for (auto it = fsn.begin(); it != fsn.end(); ++it)
        if (!it->second.IsMap() || (!it->second["model"] && !it->second["train"]))
          train_optional = false;
    }
    parseSplit(split, &s->datasets, YAML::Node(), s->f0.base_dir, d, s->train, s->test, true,
               &s->validation, &s->folds, train_optional);
    if (!s->validation.empty() && split["folds"])
      d.add(split["folds"].Mark(),
            "split: give either validation (a split of its own) or folds (cross-validation inside "
            "split.train) for select:, not both");
  } else {
    d.add(root.Mark(),
          "missing key 'split' ({train: [...], test: [...]}); train and test sets "
          "are never implied");
  }
  uniqueLabels(s->test);
  uniqueLabels(s->train);
  uniqueLabels(s->validation);
  for (auto& fold : s->folds) uniqueLabels(fold);
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
      detail::checkKeys(d, v,
                        {"extends", "stages", "features", "min_sigma", "model", "train", "energy"},
                        what, kKeyHint);
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
          f.energy.reset(detail::copyMapKeepingPositions(base->energy));
        }
      }
      // energy: this set's energy parameters (checked against the energy plugin further down).
      if (const YAML::Node en = v["energy"]) {
        if (!en.IsMap())
          d.add(en.Mark(), what +
                               ": 'energy' must be a map of energy parameters, e.g. "
                               "{preclass_layer: \"\"}");
        else
          for (auto e = en.begin(); e != en.end(); ++e) {
            // remove first: assigning to a key the base set also has would rewrite its node
            f.energy.remove(e->first.Scalar());
            f.energy[e->first.Scalar()] = e->second;
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
      // The stages' order and reads, as a run config's (a feature set's stages run after the
      // common ones). Layer reads and the features' origins wait for the items' sources (below):
      // a source may bring layers made elsewhere (Frame::grid). What only stages make is
      // judged now.
      if (f.unavailable.empty() && s->common_unavailable.empty())
        checkSetFlow(*s, f, SetFlowCheck::kNoSource, nullptr, false, reg, ctx, d);
      s->feature_sets.push_back(std::move(f));
    }
  } else {
    d.add(root["feature_sets"] ? root["feature_sets"].Mark() : root.Mark(),
          "'feature_sets' must be a non-empty map name: {stages, features}");
  }
  // optimisers
  if (const YAML::Node on = root["optimisers"];
      on && (on.IsMap() || on.IsSequence()) && on.size() > 0) {
    auto add = [&](const std::string& name, const YAML::Node& entry, const YAML::Mark& mark) {
      OptimiserDef od;
      od.name = name;
      od.entry = entry;
      od.mark = mark;
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
          e.reset(detail::copyMapKeepingPositions(e));  // errors keep their place
          e["name"] = it->first.Scalar();
        }
        add(it->first.Scalar(), e, it->first.Mark());
      }
    } else {
      for (const auto& item : on) {
        const YAML::Node e = item;
        if (e.IsScalar()) {
          YAML::Node m(YAML::NodeType::Map);
          m["type"] = e;  // the node itself, so errors keep its position
          add(e.Scalar(), m, e.Mark());
        } else {
          add(e["name"] ? e["name"].Scalar() : (e["type"] ? e["type"].Scalar() : "?"), e, e.Mark());
        }
      }
    }
  } else {
    d.add(root["optimisers"] ? root["optimisers"].Mark() : root.Mark(),
          "'optimisers' must name at least one optimiser (e.g. {icm: {type: icm}})");
  }
  // Names become folder and file names (models/<set>.yaml, runs/<data>__<set>__<optimiser>): two
  // that are equal after sanitising would overwrite each other's results.
  // Equal names in a map are repeated keys, which loadYamlFile reported already.
  auto distinctNames = [&](const std::vector<std::pair<std::string, YAML::Mark>>& names,
                           const std::string& what, bool from_map) {
    for (std::size_t i = 0; i < names.size(); ++i)
      for (std::size_t j = 0; j < i; ++j)
        if (sanitize(names[i].first) == sanitize(names[j].first) &&
            !(from_map && names[i].first == names[j].first)) {
          d.add(names[i].second, what + " '" + names[i].first + "' has the same " +
                                     (names[i].first == names[j].first ? "name" : "file name") +
                                     " as '" + names[j].first + "' (line " +
                                     std::to_string(names[j].second.line + 1) +
                                     "): their results would overwrite each other");
          break;
        }
  };
  {
    std::vector<std::pair<std::string, YAML::Mark>> names;
    for (const auto& f : s->feature_sets) names.emplace_back(f.name, f.mark);
    distinctNames(names, "feature set", true);
    names.clear();
    for (const auto& op : s->optimisers) names.emplace_back(op.name, op.mark);
    const YAML::Node on = root["optimisers"];
    distinctNames(names, "optimiser", on && on.IsMap());
  }
  // Each list's labels are unique (uniqueLabels) and so are the sets' and optimisers' names, but
  // a run's folder joins three of them: test item 'a__b' × set 'c' and item 'a' × set 'b__c'
  // would both write runs/a__b__c__<optimiser> and roc/a__b__c__<optimiser>.*.
  for (auto& g : s->train_groups) uniqueLabels(g);
  checkDistinctLabels(s->train, "split.train", d);
  checkDistinctLabels(s->validation, "split.validation", d);
  checkDistinctLabels(s->test, "split.test", d);
  for (std::size_t k = 0; k < s->folds.size(); ++k)
    checkDistinctLabels(s->folds[k], "split.folds fold " + std::to_string(k + 1), d);
  for (std::size_t k = 0; k < s->train_groups.size(); ++k)
    checkDistinctLabels(s->train_groups[k], "a feature set's train", d);
  {
    struct Run {
      std::string text;
      std::vector<std::string> parts;  // item, feature set, optimiser
    };
    std::map<std::string, Run> run_of;  // file name -> run
    for (const auto& t : s->test)
      for (const auto& f : s->feature_sets)
        for (const auto& op : s->optimisers) {
          RunRecord r;
          r.dataset = t->label;
          r.feature_set = f.name;
          r.optimiser = op.name;
          const Run run{t->label + " × " + f.name + " × " + op.name, {t->label, f.name, op.name}};
          const auto [it, added] = run_of.emplace(sanitize(r.key()), run);
          if (added) continue;
          // Names equal part by part were reported above (or are one run): only a join is new.
          bool part_by_part = true;
          for (std::size_t k = 0; k < 3; ++k)
            part_by_part = part_by_part && sanitize(run.parts[k]) == sanitize(it->second.parts[k]);
          if (part_by_part) continue;
          d.add(t->mark, "run '" + run.text + "' and run '" + it->second.text +
                             "' would both write runs/" + it->first + " and roc/" + it->first +
                             ".*: expected test items, feature sets and optimisers whose names "
                             "do not join alike with '__' (rename one of them)");
        }
  }
  // energy
  if (const YAML::Node en = root["energy"]) {
    // Copies whose keys and values keep their file positions, so a run's errors point into the
    // sweep (a clone's point at 1:1); the runs add to copies of these maps, never to the file's.
    s->energy = en.IsMap() ? detail::copyEntryKeepingPositions(en) : YAML::Clone(en);
    if (en.IsMap() && en["params"] && en["params"].IsMap())
      for (const char* k : {"model", "features"})
        if (en["params"][k])
          d.add(en["params"][k].Mark(), std::string("energy: '") + k +
                                            "' is set per feature set by compare; remove it here");
  } else {
    s->energy = YAML::Node(YAML::NodeType::Map);  // no position: the sweep does not write it
    s->energy["name"] = "mrf";
    s->energy["type"] = "potts_gaussian";
  }
  if (!s->energy.IsMap()) {
    // The clone has no position; the sweep's own node has.
    d.add(root["energy"] ? root["energy"].Mark() : root.Mark(),
          "'energy' must be an entry {name, type, params}");
  } else {
    if (!s->energy["name"]) s->energy["name"] = "mrf";
    Made m = makePlugin(reg, s->energy, "energy", {PluginKind::kEnergy}, ctx, d, true, false);
    s->energy_unavailable = m.not_installed;
    if (const YAML::Node en = root["energy"]; en && en["type"])
      checkDeclaredValues(reg, en["type"].Scalar(), en["params"], "energy.params", d);
    // Feature sets' own energy parameters: what the energy declares, except what compare sets.
    const std::string type = s->energy["type"] ? s->energy["type"].Scalar() : "";
    const std::vector<std::string> allowed = settableKeys(reg, type);
    const YAML::Node fsets = root["feature_sets"];
    if (fsets && fsets.IsMap())
      for (auto it = fsets.begin(); it != fsets.end(); ++it) {
        const YAML::Node en = it->second.IsMap() ? it->second["energy"] : YAML::Node();
        if (!en || !en.IsMap()) continue;
        const std::string what = "feature set '" + it->first.Scalar() + "' energy";
        for (const char* k : {"model", "features"})
          if (en[k])
            d.add(en[k].Mark(),
                  what + ": '" + k + "' is set per feature set by compare; remove it");
        std::vector<std::string> keys = allowed;  // model and features: reported just above
        keys.insert(keys.end(), {"model", "features"});
        if (!allowed.empty()) detail::checkKeys(d, en, keys, what, kKeyHint);
        checkDeclaredValues(reg, type, en, what, d);
      }
  }
  // training, outputs, roc
  if (const YAML::Node tr = root["training"]) {
    if (!tr.IsMap()) {
      d.add(tr.Mark(), "'training' must be a map of feature_stats parameters");
    } else {
      const std::vector<std::string> keys = settableKeys(reg, kStatsPlugin);
      if (!keys.empty()) detail::checkKeys(d, tr, keys, "training", kKeyHint);
      checkDeclaredValues(reg, kStatsPlugin, tr, "training", d);
      s->training = tr;
      s->training_mark = tr.Mark();
    }
  }
  if (const YAML::Node sel = root["select"]) {
    parseSelect(sel, *s, reg, d);
    if (s->validation.empty() && s->folds.empty())
      d.add(sel.Mark(),
            "select needs split.validation or split.folds: the candidates are scored there, "
            "never on the test split");
    if (!s->folds.empty()) {
      if (s->select.refit)
        d.add(sel["refit"].Mark(),
              "select.refit: with split.folds the chosen candidate is always learnt on the whole "
              "train split; refit is for split.validation");
      // Folds divide split.train; a feature set that learns from other items has nothing to
      // cross-validate on.
      for (const auto& f : s->feature_sets)
        if (f.train_group >= 0 && f.model.empty())
          d.add(f.mark, "feature set '" + f.name +
                            "': trains on its own 'train:' items, but split.folds divide "
                            "split.train; give select: a split.validation instead, or the "
                            "feature set a model");
    }
  } else if (!s->validation.empty()) {
    s->notes.push_back("split.validation is only used by 'select:', which this sweep has not");
  } else if (!s->folds.empty()) {
    s->notes.push_back("split.folds are only used by 'select:', which this sweep has not");
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
  std::size_t cache_mb = 2048;
  if (const YAML::Node c = root["frame_cache_mb"]) {
    try {
      const long v = c.as<long>();
      if (v < 0 || v > (1L << 24)) throw YAML::Exception(c.Mark(), "");
      cache_mb = static_cast<std::size_t>(v);
    } catch (const YAML::Exception&) {
      d.add(c.Mark(),
            "frame_cache_mb: expected megabytes of frames to keep in memory between "
            "runs, an integer >= 0 (0 = read every frame every time)");
    }
  }
  if (cache_mb > 0) {
    s->frame_cache = std::make_shared<FrameBudget>();
    s->frame_cache->left = cache_mb << 20;
  }
  if (const YAML::Node roc = root["roc"]) {
    if (!roc.IsMap()) {
      d.add(roc.Mark(), "'roc' must be a map {max_points, fallback}");
    } else {
      detail::checkKeys(d, roc, {"max_points", "fallback"}, "roc", kKeyHint);
      if (roc["max_points"]) {
        try {
          const int v = roc["max_points"].as<int>();
          if (v < 2 || v > RocAccumulator::kMaxCurvePoints)
            throw YAML::Exception(roc["max_points"].Mark(), "");
          s->roc_max_points = static_cast<std::size_t>(v);
        } catch (const YAML::Exception&) {
          d.add(roc["max_points"].Mark(), "roc.max_points: expected an integer from 2 to " +
                                              std::to_string(RocAccumulator::kMaxCurvePoints));
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
  for (auto& it : s->validation) identify(*it, s->f0.base_dir, reg);
  for (auto& fold : s->folds)
    for (auto& it : fold) identify(*it, s->f0.base_dir, reg);
  for (auto& g : s->train_groups)
    for (auto& it : g) identify(*it, s->f0.base_dir, reg);
  std::vector<Item*> tr, te, va;
  for (auto& it : s->train) tr.push_back(it.get());
  for (auto& g : s->train_groups)
    for (auto& it : g) tr.push_back(it.get());
  for (auto& it : s->test) te.push_back(it.get());
  for (auto& it : s->validation) va.push_back(it.get());
  checkDisjoint(tr, te, d, "test", "train", &s->notes);
  // Validation data must be unseen in training, and choosing on it must not peek at the test.
  checkDisjoint(tr, va, d, "validation", "train");
  checkDisjoint(va, te, d, "test", "validation");
  {
    std::vector<Item*> split_train;
    for (auto& it : s->train) split_train.push_back(it.get());
    checkFolds(split_train, s->folds, d);
  }
  d.throwIfAny();
  for (auto& it : s->train)
    prepareItem(*it, reg, s->f0, s->output_dir, limit, d, true, s->frame_cache);
  for (auto& g : s->train_groups)
    for (auto& it : g) prepareItem(*it, reg, s->f0, s->output_dir, limit, d, true, s->frame_cache);
  for (auto& it : s->test)
    prepareItem(*it, reg, s->f0, s->output_dir, limit, d, true, s->frame_cache);
  for (auto& it : s->validation)
    prepareItem(*it, reg, s->f0, s->output_dir, limit, d, true, s->frame_cache);
  for (auto& fold : s->folds)
    for (auto& it : fold)
      prepareItem(*it, reg, s->f0, s->output_dir, limit, d, true, s->frame_cache);
  // Each feature set's stages and features against the sources of the items it runs on (its
  // training items unless it brings its model, validation or folds when select: chooses for it,
  // the test items): items whose sources bring the same layers are checked once.
  for (const FeatureSet& f : s->feature_sets) {
    if (!f.unavailable.empty() || !s->common_unavailable.empty()) continue;
    std::vector<const Item*> items;
    if (f.model.empty())
      for (const auto& it : trainItems(*s, f)) items.push_back(it.get());
    // A set with its own model is still scored there when select: chooses its energy.
    if (selectsFor(candidatesFor(s->select, f))) {
      for (const auto& it : s->validation) items.push_back(it.get());
      for (const auto& fold : s->folds)
        for (const auto& it : fold) items.push_back(it.get());
    }
    for (const auto& it : s->test) items.push_back(it.get());
    // By the layers they bring (frame artefacts such as '@pose' are judged per run).
    std::map<std::vector<std::string>, const Item*> by_writes;
    for (const Item* it : items)
      if (it->src) by_writes.emplace(broughtLayers(*it->src), it);  // else not installed/reported
    bool any_brought = false;
    for (const auto& [brought, it] : by_writes) any_brought |= !brought.empty();
    const bool name_item = by_writes.size() > 1 || any_brought;
    // No item's source made (not installed: its runs are skipped; or it failed, reported):
    // what the sources would bring is unknown, so nothing more is judged, as for run configs.
    // In the order the items are listed, for messages that follow the file.
    for (const Item* it : items)
      if (it->src && by_writes.at(broughtLayers(*it->src)) == it)
        checkSetFlow(*s, f, SetFlowCheck::kItem, it, name_item, reg, ctx, d);
  }
  std::set<std::string> used;
  for (auto& it : s->train) used.insert(it->dataset);
  for (auto& g : s->train_groups)
    for (auto& it : g) used.insert(it->dataset);
  for (auto& it : s->test) used.insert(it->dataset);
  for (auto& it : s->validation) used.insert(it->dataset);
  for (const auto& [name, node] : s->datasets)
    if (!used.count(name))
      s->notes.push_back("dataset '" + name + "' is in no split (train, validation, test)");
  d.throwIfAny();
  return s;
}

}  // namespace sweep_detail

}  // namespace terramrf
