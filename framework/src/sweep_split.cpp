// Split items of train configs and sweeps: parsing, the identity of their data, the check that
// train and test sets are disjoint, and configuring their sources.
#include <algorithm>
#include <filesystem>
#include <map>
#include <set>
#include <utility>

#include "config_internal.hpp"
#include "param_yaml.hpp"
#include "sweep_internal.hpp"
#include "terramrf/param_values.hpp"
#include "terramrf/sweep.hpp"

namespace terramrf {
namespace fs = std::filesystem;

std::string FrameRange::str() const {
  if (all()) return "all frames";
  if (first == last) return "frame " + std::to_string(first);
  if (last == npos) return "frames " + std::to_string(first) + "-end";
  return "frames " + std::to_string(first) + "-" + std::to_string(last);
}

namespace sweep_detail {
namespace {

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

std::string itemText(const Item& it) {
  return "'" + it.label + "' (" + it.frames.str() + " of " + it.identity_text + ")";
}

}  // namespace
}  // namespace sweep_detail

namespace sweep_detail {

void identify(Item& it, const std::string& base_dir, PluginRegistry& reg) {
  const YAML::Node params = it.source["params"];
  if (params && params.IsMap() && params["path"] && params["path"].IsScalar()) {
    it.path = canonicalPath(absPath(base_dir, params["path"].Scalar()));
    it.identity_text = it.path;
    return;
  }
  std::map<std::string, std::string> kv;
  std::map<std::string, ParamSpec> specs;
  if (const PluginInfo* info = reg.find(it.type)) {
    (void)info;
    try {
      auto p = reg.create(it.type);
      for (auto& s : declaredParams(*p)) {
        kv[s.name] = toYaml(s.default_value);
        specs.emplace(s.name, std::move(s));
      }
    } catch (const std::exception&) {
    }
  }
  if (params && params.IsMap()) {
    for (auto p = params.begin(); p != params.end(); ++p) {
      // Compared as the plugin takes them, not as written: `seed: 07` is world 7 too.
      const auto spec = specs.find(p->first.Scalar());
      std::string value =
          spec == specs.end() ? "" : detail::canonicalParamValue(spec->second, p->second);
      if (value.empty()) {
        YAML::Emitter em;
        em << YAML::Flow << p->second;
        value = em.c_str();
      }
      kv[p->first.Scalar()] = value;
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
    detail::checkKeys(d, n, keys, "split item", kKeyHint);
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
  // Copies that keep the file positions, so a bad parameter is reported where it is written;
  // the dataset's own nodes stay untouched for the other items that use it.
  it.source = detail::copyEntryKeepingPositions(base);
  YAML::Node params = it.source["params"];
  // Messages about the source then name the dataset, not only its type.
  if (!it.dataset.empty() && !it.source["name"]) it.source["name"] = it.dataset;
  // Parameters that are not a map are reported when the source is made; nothing to add to.
  const bool settable = params.IsMap();
  if (params_override && settable)
    for (auto p = params_override.begin(); p != params_override.end(); ++p) {
      params.remove(p->first.Scalar());
      params[p->first] = p->second;
    }
  if (!path_override.empty()) {
    const std::string abs = absPath(base_dir, path_override);
    if (!fs::exists(abs)) {
      d.add(n.Mark(), "data folder '" + abs + "' does not exist");
      return false;
    }
    if (settable) {
      params.remove("path");
      params["path"] = abs;
    }
    it.path_written = path_override;
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

void checkDisjoint(const std::vector<Item*>& train, const std::vector<Item*>& test, Diags& d,
                   const std::string& test_role, const std::string& train_role,
                   std::vector<std::string>* notes) {
  for (const Item* t : test) {
    for (const Item* r : train) {
      std::string why, same;  // `same`: one recording or world, other frames
      if (!t->path.empty() && !r->path.empty()) {
        if (t->path == r->path) {
          if (t->frames.overlaps(r->frames)) {
            const std::size_t a = std::max(t->frames.first, r->frames.first);
            const std::size_t b = std::min(t->frames.last, r->frames.last);
            why = "both read " + t->path + ", " + FrameRange{a, b}.str() + " in both";
          } else {
            same = t->path;
          }
        } else if (pathWithin(t->path, r->path) || pathWithin(r->path, t->path)) {
          why = "one data folder contains the other (" + r->path + " / " + t->path + ")";
        }
      } else if (t->path.empty() && r->path.empty() && t->identity == r->identity) {
        if (t->frames.overlaps(r->frames)) {
          const std::size_t a = std::max(t->frames.first, r->frames.first);
          const std::size_t b = std::min(t->frames.last, r->frames.last);
          why = "same source and parameters (" + t->identity_text + "), " + FrameRange{a, b}.str() +
                " in both";
        } else {
          same = t->identity_text;
        }
      }
      if (!same.empty() && notes)
        notes->push_back(test_role + " item " + itemText(*t) + " and " + train_role + " item " +
                         itemText(*r) + " read the same recording (" + same +
                         ") in other frames: allowed, but frames of one drive share its ground "
                         "and objects, so the " +
                         test_role + " figures are not those of unseen data");
      if (why.empty()) continue;
      std::string where;
      if (r->mark.line >= 0) where = " at line " + std::to_string(r->mark.line + 1);
      d.add(t->mark, "split: " + test_role + " item " + itemText(*t) + " overlaps " + train_role +
                         " item " + itemText(*r) + where + ": " + why + "; " + train_role +
                         " and " + test_role + " sets must be disjoint");
    }
  }
}

std::string Item::described(const std::string& note) const {
  FrameRange r = frames;
  const std::size_t end = frames.last == FrameRange::npos ? size : frames.last + 1;
  if (count > 0 && first + count < end) r = FrameRange{first, first + count - 1};  // --limit
  return label + " (" + r.str() + (note.empty() ? "" : ", " + note) + ")";
}

void prepareItem(Item& it, PluginRegistry& reg, const Frame0& f0, const std::string& out_dir,
                 std::size_t limit, Diags& d, bool tolerate_missing,
                 const std::shared_ptr<FrameBudget>& cache) {
  Made m = makePlugin(reg, it.source, "source", {PluginKind::kSource}, f0.context(out_dir), d,
                      tolerate_missing);
  if (!m.ok()) {
    it.unavailable = m.not_installed;
    return;
  }
  it.src.reset(static_cast<Source*>(m.plugin.release()));
  if (it.src->streaming()) {
    // Training and sweeps read each frame many times and split the frames by index: a stream
    // (frames as they arrive, how many unknown) gives neither. Said at the entry's type.
    d.add(detail::valueMark(it.source, "type"),
          (it.dataset.empty() ? "source '" + it.type + "'"
                              : "dataset '" + it.dataset + "' (source " + it.type + ")") +
              " is a stream (Source::streaming(): frames as they arrive, how many unknown); "
              "train and compare need a batch they can read again and split by frame index: "
              "give a source (or parameters) that indexes its frames, or run the stream with "
              "'terramrf run'");
    it.src.reset();
    return;
  }
  if (cache) it.src = std::make_unique<CachedSource>(std::move(it.src), cache);
  it.size = it.src->size();
  // A range past the end is an error, not a shorter range: the split would silently hold fewer
  // frames than the sweep says. Only an open range (no `frames:`) takes what there is.
  if (it.frames.first >= it.size ||
      (it.frames.last != FrameRange::npos && it.frames.last >= it.size)) {
    d.add(it.mark, "split item '" + it.label + "' asks for " + it.frames.str() +
                       " but the source has " + std::to_string(it.size) + " frame(s)" +
                       (it.size ? " (0–" + std::to_string(it.size - 1) + ")" : std::string()));
    it.src.reset();
    return;
  }
  const std::size_t last = std::min(it.frames.last, it.size - 1);
  it.first = it.frames.first;
  it.count = last - it.first + 1;
  if (limit > 0) it.count = std::min(it.count, limit);
}

void parseSplit(const YAML::Node& split, const std::map<std::string, YAML::Node>* datasets,
                const YAML::Node& base_source, const std::string& base_dir, Diags& d,
                std::vector<std::unique_ptr<Item>>& train, std::vector<std::unique_ptr<Item>>& test,
                bool need_both, std::vector<std::unique_ptr<Item>>* validation,
                std::vector<std::vector<std::unique_ptr<Item>>>* folds, bool train_optional) {
  if (!split.IsMap()) {
    d.add(split.Mark(), "'split' must be a map {train: [...], test: [...]}");
    return;
  }
  if (validation && folds)
    detail::checkKeys(d, split, {"train", "validation", "folds", "test"}, "split", kKeyHint);
  else if (validation)
    detail::checkKeys(d, split, {"train", "validation", "test"}, "split", kKeyHint);
  else
    detail::checkKeys(d, split, {"train", "test"}, "split", kKeyHint);
  auto list = [&](const char* key, std::vector<std::unique_ptr<Item>>& out) {
    const YAML::Node l = split[key];
    if (!l) {
      if (std::string(key) == "validation") return;  // optional
      if (std::string(key) == "train" && train_optional) return;
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
  if (validation) list("validation", *validation);
  list("test", test);
  if (!folds) return;
  const YAML::Node f = split["folds"];
  if (!f) return;
  if (!f.IsSequence() || f.size() < 2) {
    d.add(f.Mark(),
          "split.folds: expected a list of at least two folds, each a list of items of split.train");
    return;
  }
  for (std::size_t k = 0; k < f.size(); ++k) {
    const YAML::Node fold = f[k];
    std::vector<std::unique_ptr<Item>> items;
    if (fold.IsSequence() && fold.size() == 0) {
      d.add(fold.Mark(), "split.folds: fold " + std::to_string(k + 1) + " is empty");
      continue;
    }
    const std::vector<YAML::Node> entries =
        fold.IsSequence() ? std::vector<YAML::Node>(fold.begin(), fold.end())
                          : std::vector<YAML::Node>{fold};
    for (const auto& n : entries) {
      auto it = std::make_unique<Item>();
      if (parseItem(n, datasets, base_source, base_dir, d, *it)) items.push_back(std::move(it));
    }
    folds->push_back(std::move(items));
  }
}

void checkFolds(const std::vector<Item*>& train,
                const std::vector<std::vector<std::unique_ptr<Item>>>& folds, Diags& d) {
  auto inside = [](const FrameRange& a, const FrameRange& b) {  // a within b
    return b.first <= a.first && a.last <= b.last;
  };
  for (std::size_t k = 0; k < folds.size(); ++k) {
    for (const auto& f : folds[k]) {
      bool found = false;
      for (const Item* t : train) {
        const bool same = !f->path.empty() ? f->path == t->path
                                           : t->path.empty() && f->identity == t->identity;
        if (same && inside(f->frames, t->frames)) found = true;
      }
      if (!found)
        d.add(f->mark, "split.folds: fold " + std::to_string(k + 1) + " item " + itemText(*f) +
                           " is not part of split.train (same data, frames inside a train "
                           "item's); folds divide the train split");
    }
    std::vector<Item*> mine;
    for (const auto& f : folds[k]) mine.push_back(f.get());
    for (std::size_t j = 0; j < k; ++j) {
      std::vector<Item*> other;
      for (const auto& f : folds[j]) other.push_back(f.get());
      checkDisjoint(other, mine, d, "fold " + std::to_string(k + 1) + "'s",
                    "fold " + std::to_string(j + 1) + "'s");
    }
  }
}

namespace {

/// Items whose labels are equal once made file names (sanitize: "a b" and "a_b" are one folder),
/// in groups of two or more, in list order.
std::vector<std::vector<Item*>> labelCollisions(const std::vector<std::unique_ptr<Item>>& items) {
  std::map<std::string, std::size_t> group_of;
  std::vector<std::vector<Item*>> groups;
  for (const auto& it : items) {
    const auto [g, added] = group_of.emplace(sanitize(it->label), groups.size());
    if (added) groups.emplace_back();
    groups[g->second].push_back(it.get());
  }
  groups.erase(std::remove_if(groups.begin(), groups.end(),
                              [](const std::vector<Item*>& g) { return g.size() < 2; }),
               groups.end());
  return groups;
}

/// A parameter value as a reader of the tables would write it ("0.3", "[1, 2]").
std::string valueText(const YAML::Node& v) {
  if (v.IsScalar()) return v.Scalar();
  YAML::Emitter em;
  em << YAML::Flow << v;
  return em.c_str();
}

}  // namespace

void uniqueLabels(std::vector<std::unique_ptr<Item>>& items) {
  // Labels name the rows and columns of every table and the run folders (runs/<label>__F__O,
  // roc/…, select/…/runs/…__<label>, models/<F>.train/<label>): two equal ones overwrite each
  // other's folders and SweepResult::find shows the first twice. Until they differ, colliding
  // items get what tells them apart, most readable first.
  // 1. The frame range, when one was given (the usual case: one recording split by frames).
  for (const auto& g : labelCollisions(items))
    for (Item* it : g)
      if (it->range_given)
        it->label += "[" + std::to_string(it->frames.first) + "-" +
                     (it->frames.last == FrameRange::npos ? std::string("end")
                                                          : std::to_string(it->frames.last)) +
                     "]";
  // 2. The source parameters in which they differ (`params:` or `path:` of the item): "sim_test
  //    range_noise_m=0.3". A parameter one item sets and another leaves to its default is shown
  //    where it is set.
  for (const auto& g : labelCollisions(items)) {
    std::set<std::string> keys;
    for (const Item* it : g)
      if (const YAML::Node p = std::as_const(it->source)["params"]; p && p.IsMap())
        for (auto kv = p.begin(); kv != p.end(); ++kv) keys.insert(kv->first.Scalar());
    std::vector<std::string> suffix(g.size());
    for (const std::string& k : keys) {
      std::vector<std::string> values(g.size());
      for (std::size_t i = 0; i < g.size(); ++i) {
        const YAML::Node p = std::as_const(g[i]->source)["params"];  // const: adds no key
        if (p && p.IsMap() && p[k]) values[i] = valueText(p[k]);
      }
      if (std::all_of(values.begin(), values.end(),
                      [&](const std::string& v) { return v == values[0]; }))
        continue;
      for (std::size_t i = 0; i < g.size(); ++i) {
        if (values[i].empty()) continue;
        // The path as written in the sweep, not the absolute one the source is given.
        const std::string& shown =
            k == "path" && !g[i]->path_written.empty() ? g[i]->path_written : values[i];
        suffix[i] += " " + k + "=" + shown;
      }
    }
    for (std::size_t i = 0; i < g.size(); ++i) g[i]->label += suffix[i];
  }
  // 3. Their place in the list (the same data twice, or parameters that read alike): "#2" is
  //    the list's second item.
  for (const auto& g : labelCollisions(items))
    for (Item* it : g)
      for (std::size_t i = 0; i < items.size(); ++i)
        if (items[i].get() == it) it->label += " #" + std::to_string(i + 1);
}

void checkDistinctLabels(const std::vector<std::unique_ptr<Item>>& items,
                         const std::string& list_name, Diags& d) {
  for (const auto& g : labelCollisions(items)) {
    for (std::size_t i = 1; i < g.size(); ++i)
      d.add(g[i]->mark,
            list_name + " item '" + g[i]->label + "' has the same name as item '" + g[0]->label +
                "'" +
                (g[0]->mark.line >= 0 ? " (line " + std::to_string(g[0]->mark.line + 1) + ")"
                                      : std::string()) +
                " once made a file name ('" + sanitize(g[i]->label) +
                "'): their run folders and table rows would overwrite each other; expected "
                "distinct names (rename one of them)");
  }
}

}  // namespace sweep_detail

}  // namespace terramrf
