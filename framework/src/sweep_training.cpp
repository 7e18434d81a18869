// `terramrf train`: runs the feature stages over the training items and learns the per-class
// feature model with the feature_stats output plugin.
#include <chrono>
#include <filesystem>
#include <iostream>
#include <set>
#include <sstream>

#include "config_internal.hpp"
#include "sweep_internal.hpp"
#include "terramrf/atomic_file.hpp"
#include "terramrf/param_values.hpp"
#include "terramrf/stop_request.hpp"
#include "terramrf/sweep.hpp"
#include "terramrf/version.hpp"

namespace terramrf {
namespace fs = std::filesystem;

namespace sweep_detail {
namespace {

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

/// The features' origins as feature_stats writes them in a run, for the models train writes
/// (its feature_stats is made apart from the stages, so it never sees them itself).
std::string originsText(const TrainResult& r) {
  std::string out;
  for (const auto& f : r.features)
    if (const auto it = r.layer_origins.find(f); it != r.layer_origins.end())
      out += "  " + f + ": " + it->second + "\n";
  return out.empty() ? out
                     : "feature_origins:  # how each feature was computed: stage, parameters, "
                       "inputs\n" +
                           out;
}

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
  em << YAML::Key << "date" << YAML::Value << creationTime();
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
  // Always written: an empty list says that nothing was declared held out, so no test scan can
  // be proven unseen by this model.
  em << YAML::Key << "held_out" << YAML::Value << YAML::Flow << job.held_out;
  if (!r.missing.empty()) em << YAML::Key << "not_learnt" << YAML::Value << YAML::Flow << r.missing;
  em << YAML::EndMap << YAML::EndMap;
  return "# Per-class Gaussian feature model (paper 000 §4.6), learnt from annotated cells by\n"
         "# 'terramrf train' / 'terramrf compare' with the feature_stats output; loads in "
         "potts_gaussian.\n" +
         std::string(em.c_str()) + "\n" + originsText(r) + classes;
}

}  // namespace
}  // namespace sweep_detail

namespace sweep_detail {

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
  entry["name"] = kStatsPlugin;
  entry["type"] = kStatsPlugin;
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

  // Per feature, the first item whose source or stages said how it is computed, and how.
  std::map<std::string, std::pair<std::string, std::string>> first_origin;
  for (Item* it : job.items) {
    TrainedItem rec;
    rec.label = it->label;
    rec.source_type = it->type;
    rec.frames = FrameRange{it->first, it->first + it->count - 1};  // after range and --limit
    if (hasParam(*it->src, "path")) rec.path = paramString(*it->src, "path");
    if (hasParam(*it->src, "label_map")) {
      rec.label_map = paramString(*it->src, "label_map");
      if (rec.label_map.empty()) rec.label_map = "(source default)";  // a source that keeps ""
    } else {
      rec.label_map = "(none: the source has no label map)";
    }
    std::vector<std::unique_ptr<Output>> extra;
    extra.push_back(std::make_unique<StatsFeeder>(*stats, rec, progress, job.what + it->label));
    Pipeline p = assemble(reg, f0, *it, job.stages, {}, std::move(extra), model_dir);
    // Every item runs the same stages, but items' sources may bring layers with origins of
    // their own (logs of other senders): a feature computed two ways cannot make one model, and
    // one whose origin some item does not know is recorded as unknown (not checked).
    if (it == job.items.front()) r.layer_origins = p.layer_origins;
    for (const auto& f : job.features) {
      const auto mine = p.layer_origins.find(f);
      if (mine == p.layer_origins.end()) {
        r.layer_origins.erase(f);  // unknown for some of the data: recorded as unknown
        continue;
      }
      // Compared with the first item that knew it, even after another item did not.
      const auto [first, fresh] = first_origin.try_emplace(f, it->label, mine->second);
      if (!fresh && first->second.second != mine->second)
        throw std::runtime_error("training items '" + first->second.first + "' and '" + it->label +
                                 "' bring feature '" + f + "' computed otherwise (" +
                                 first->second.second + " against " + mine->second +
                                 "); one model cannot fit both: train on data whose layers were "
                                 "computed alike; no model written (" +
                                 job.model_path + " is left as it was)");
    }
    // The features must be layers some stage writes, or the source brings made (Frame::grid:
    // a log of another process's feature layers).
    std::set<std::string> written;
    for (const auto& w : it->src->writes()) written.insert(w);
    for (const auto& s : p.stages)
      for (const auto& w : s->writes()) written.insert(w);
    for (const auto& f : job.features) {
      if (written.count(f)) continue;
      std::string have;
      for (const auto& w : written)
        if (w[0] != '@') have += (have.empty() ? "" : ", ") + w;
      Diags fd;
      fd.file = f0.file;
      fd.add(job.features_mark,
             (job.features_from_command_line ? "--features: feature '" : "feature '") + f +
                 "' is not written by any stage or the source (written: " +
                 (have.empty() ? "none" : have) + ")");
      fd.throwIfAny();
    }
    RunResult rr;
    {
      // runPipeline writes resolved_config.yaml into the output folder; keep it per item.
      p.output_dir = job.run_root + "/" + sanitize(it->label);
      SourceLoan loan(*it, p);
      rr = runPipeline(p, runOptions(*it, &log, /*timed=*/false));
    }
    progress.advanceTo(0, job.what + it->label);
    if (rr.summary.stop_signal != 0) {
      // A model learnt from part of the data would pass for one learnt from all of it, and
      // replace a good one: none is written.
      progress.breakLine();
      throw std::runtime_error("training " + interruptionText(rr.summary) + " of item '" +
                               it->label + "'; no model written (" + job.model_path +
                               " is left as it was): one learnt from part of the data would "
                               "pass for one learnt from all of it");
    }
    if (!rr.output_errors.empty()) {
      // A stage failed at the end of the item's run (its only outputs are ours, which cannot):
      // that fails `terramrf run` (status 4) and must not pass unseen here.
      std::string errors;
      for (const auto& e : rr.output_errors) errors += (errors.empty() ? "" : "; ") + e;
      progress.breakLine();
      throw std::runtime_error("training item '" + it->label + "': " + errors +
                               "; no model written (" + job.model_path + " is left as it was)");
    }
    rec.failed_frames = rr.summary.failed.size();
    for (const auto& f : rr.summary.failed) r.failed.push_back(f);
    r.frames += rec.frame_ids.size();
    r.labelled_frames += rec.labelled_frames;
    r.items.push_back(rec);
  }
  if (r.labelled_frames == 0 && r.frames == 0 && !r.failed.empty())
    throw std::runtime_error("every training frame failed (" + std::to_string(r.failed.size()) +
                             "); the first, " + r.failed[0].first + ": " + r.failed[0].second);
  if (r.labelled_frames == 0) {
    std::string what;
    // A sweep item has a label; `terramrf train` reads one source, labelled by its folder if
    // anything: name it by what it is.
    for (const auto& it : r.items)
      what += (what.empty() ? "" : "; ") +
              (it.label.empty() || it.label == it.path ? "source " + it.source_type : it.label) +
              (it.path.empty() ? "" : " at " + it.path) + ", label map " + it.label_map;
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
    // A class is {feature: …} or a mixture {components: [{weight, features: {feature: …}}]}.
    auto learnt = [](const YAML::Node& cls, const std::string& f) {
      if (!cls) return false;
      if (const YAML::Node comps = cls["components"]) return comps[0]["features"][f].IsDefined();
      return cls[f].IsDefined();
    };
    for (std::size_t c = 1; c < f0.labels->size(); ++c) {
      const std::string cls = f0.labels->name(static_cast<LabelId>(c));
      for (const auto& f : job.features)
        if (!classes || !learnt(classes[cls], f)) r.missing.push_back(cls + "." + f);
    }
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(tmp + ": feature_stats wrote an unreadable model: " + e.what());
  }
  // A model without a single learnt class is refused by feature_stats itself (its end()).
  writeFileAtomic(r.model_path, composeModel(text, job, r));
  return r;
}

}  // namespace sweep_detail

using sweep_detail::checkDisjoint;
using sweep_detail::Diags;
using sweep_detail::Frame0;
using sweep_detail::identify;
using sweep_detail::Item;
using sweep_detail::kKeyHint;
using sweep_detail::kStatsPlugin;
using sweep_detail::parseSplit;
using sweep_detail::pluginDirs;
using sweep_detail::prepareItem;
using sweep_detail::Progress;
using sweep_detail::readFrame0;
using sweep_detail::runTraining;
using sweep_detail::stringList;
using sweep_detail::TrainJob;
using sweep_detail::uniqueLabels;

namespace {
/// Names each item by what it reads and checks that no test item overlaps a train item.
void identifyAndCheckDisjoint(std::vector<std::unique_ptr<Item>>& train,
                              std::vector<std::unique_ptr<Item>>& test, const std::string& base_dir,
                              PluginRegistry& reg, Diags& d, const std::string& train_note = "",
                              std::vector<std::string>* notes = nullptr) {
  // Train configs have no dataset names: an item is named by what it reads (the canonical data
  // folder, or the source type and its distinguishing parameters), which is what a model's
  // provenance and held_out must say, not a path relative to the config or a bare type.
  for (auto* items : {&train, &test})
    for (auto& it : *items) {
      identify(*it, base_dir, reg);
      if (!it->identity_text.empty()) it->label = it->identity_text;
    }
  // Two items of one source (two frame ranges, the same folder twice) would share that name: in
  // the model's data list, the messages and the per-item run folders (run_root/<label>).
  uniqueLabels(train);
  uniqueLabels(test);
  std::vector<Item*> tr, te;
  for (auto& it : train) tr.push_back(it.get());
  for (auto& it : test) te.push_back(it.get());
  if (train_note.empty()) {
    checkDisjoint(tr, te, d, "test", "train", notes);
    return;
  }
  // --data items have no position in the file; name them in the message instead.
  Diags od;
  od.file = d.file;
  checkDisjoint(tr, te, od, "test", "train", notes);
  for (auto& x : od.list) x.message += train_note;
  od.throwIfAny();
}
}  // namespace

std::vector<std::string> checkTrainSplit(const std::string& config_path,
                                         const std::vector<std::string>& plugin_dirs) {
  Diags d;
  d.file = config_path;
  const YAML::Node root = detail::loadYamlFile(config_path, d, "file");
  const YAML::Node split = root.IsMap() ? root["split"] : YAML::Node();
  if (!split) return {};
  PluginRegistry reg(pluginDirs(plugin_dirs));
  Frame0 f0;
  f0.file = config_path;
  f0.base_dir = fs::absolute(config_path).parent_path().lexically_normal().string();
  readFrame0(root, f0, d, reg);
  std::vector<std::unique_ptr<Item>> train, test;
  parseSplit(split, nullptr, root["source"], f0.base_dir, d, train, test, false);
  d.throwIfAny();
  std::vector<std::string> notes;
  identifyAndCheckDisjoint(train, test, f0.base_dir, reg, d, "", &notes);
  d.throwIfAny();
  // Each item's source as `train` makes it: its parameters, and its frames within the source.
  for (auto* items : {&train, &test})
    for (auto& it : *items) prepareItem(*it, reg, f0, f0.base_dir, 0, d, false);
  d.throwIfAny();
  return notes;
}

TrainResult trainModel(const TrainOptions& o) {
  std::ostream& log = o.log ? *o.log : std::cerr;
  if (o.model_out.empty()) throw std::runtime_error("no model file given (--out MODEL)");
  // A bad SOURCE_DATE_EPOCH is refused now, not when the model is written after training.
  (void)sweep_detail::creationTime();
  PluginRegistry reg(pluginDirs(o.plugin_dirs));
  Diags d;
  d.file = o.config_path;
  const YAML::Node root = detail::loadYamlFile(o.config_path, d, "file");
  detail::requireTopLevelMap(
      root, d, "expected a pipeline config (a map with version, grid, source, stages)");
  detail::refuseOtherKind(root, detail::FileKind::kPipeline, d);
  detail::checkKeys(d, root, detail::kPipelineKeys, "the config", kKeyHint);
  detail::checkVersion(root, d);
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
      if (!e.IsMap() || !e["type"] || e["type"].Scalar() != kStatsPlugin) continue;
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
    job.features_mark = YAML::Mark::null_mark();
    job.features_from_command_line = true;
    // A list of floors is one per feature of the config's own list, in its unit: carried over
    // by name, never by position (a floor of 0.0001 for normal_eigenvalue put on roughness
    // changed its σ fivefold). A single value is for every feature and stays.
    const YAML::Node ms = stats_params["min_sigma"];
    if (ms && ms.IsSequence() && ms.size() > 1 && fs_features != job.features) {
      YAML::Node mapped(YAML::NodeType::Sequence);
      bool all_named = ms.size() == fs_features.size();
      for (const auto& f : job.features) {
        const auto at = std::find(fs_features.begin(), fs_features.end(), f);
        if (!all_named || at == fs_features.end()) {
          all_named = false;
          break;
        }
        mapped.push_back(ms[std::size_t(at - fs_features.begin())]);
      }
      stats_params.remove("min_sigma");
      if (all_named) {
        stats_params["min_sigma"] = mapped;
      } else {
        log << "note: the config's feature_stats min_sigma list is for its own features, which "
               "do not include every one of --features; using the plugin default for them\n";
      }
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
      it->source = detail::copyEntryKeepingPositions(source);
      it->source["params"].remove("path");
      it->source["params"]["path"] = abs;
      it->type = it->source["type"] ? it->source["type"].Scalar() : "";
      it->label = abs;
      it->mark = source.Mark();
      train.push_back(std::move(it));
    }
  } else if (!root["split"]) {
    // Explicit in the config (its source is the training data) but worth saying: nothing is
    // held out, and the model records that.
    log << "note: " << o.config_path
        << " has no split: training on every frame of its source; no test data is held out "
           "(give split: {train: [...], test: [...]} to record one)\n";
    auto it = std::make_unique<Item>();
    it->source = detail::copyEntryKeepingPositions(source);
    it->type = it->source["type"] ? it->source["type"].Scalar() : "";
    it->label = "source";
    it->mark = source.Mark();
    train.push_back(std::move(it));
  }
  d.throwIfAny();
  std::vector<std::string> split_notes;
  identifyAndCheckDisjoint(train, test, f0.base_dir, reg, d,
                           o.data.empty() ? "" : " (train item from --data)", &split_notes);
  for (auto& it : test) job.held_out.push_back(it->described());
  d.throwIfAny();
  for (const auto& n : split_notes) log << "note: " << n << "\n";

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

}  // namespace terramrf
