// Learns the per-class Gaussian feature model of paper 000 §4.6 from annotated cells: for every
// cell whose labelled points agree on one class (purity), each feature value is added to that
// class's running mean/variance. The model file it writes is what potts_gaussian loads, with a
// provenance line naming the config and frames it came from.
//
// With `components` > 1 each class is a mixture of diagonal Gaussians instead, learnt by
// classification EM: a class such as "obstacle" is a union of physically different things
// (smooth, tall walls and car bodies; rough vegetation; low rocks), and one Gaussian per feature
// fits none of them — with robust estimates it fits the majority and treats the rest as outliers.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "reservoir_sample.hpp"
#include "terramrf/atomic_file.hpp"
#include "terramrf/plugin.hpp"

namespace terramrf {

class FeatureStats final : public Output {
 public:
  void declare(ParamDecl& d) override {
    d.add("features", features_, "grid layers to model").required().unique();
    d.add("model", out_path_, "model file to write (relative to the output folder)");
    d.add("min_purity", min_purity_,
          "a cell is a training sample of class c if at least this fraction of its labelled "
          "points are c").unit("1").range(0.5, 1.0);
    d.add("min_labelled_points", min_points_, "cells with fewer labelled points are not used")
        .unit("points").range(1, 100000);
    d.add("min_sigma", min_sigma_,
          "lower bound on σ per feature (one value for all, or one per feature, in the feature's "
          "unit): keeps a feature that is nearly constant in the training data from vetoing a "
          "class on unseen data")
        .unit("unit of each feature")
        .min(0);
    d.add("estimator", estimator_,
          "how mean and σ are estimated: moments (sample mean and standard deviation, paper 000 "
          "§4.6) or robust (median and 1.4826 × median absolute deviation: a few mislabelled "
          "cells at class borders no longer inflate σ)")
        .choices({"moments", "robust"});
    d.add("components", components_,
          "Gaussians per class: 1 = paper 000's model; more = a mixture of diagonal Gaussians, "
          "learnt by classification EM (cells assigned to their most likely component, each "
          "component estimated with `estimator`), started from quantiles of the first feature; "
          "components left with fewer than 10 cells are dropped")
        .unit("Gaussians")
        .range(1, 8);
    d.add("obstacle_rule", obstacle_rule_,
          "a cell holding at least one ground-truth obstacle point is an obstacle sample whatever "
          "its purity, as in the cell-wise evaluation of paper 001 §VI-B (the class the "
          "classifier is scored against)");
    d.add("max_sample_cells", max_cells_,
          "cells per class (and per feature) kept for the robust estimates and the mixtures; "
          "beyond, a uniform sample of the run's cells (reservoir sampling, the same on every run) "
          "is kept, so memory stays bounded. Means and σ of `moments` use every cell")
        .unit("cells")
        .range(1000, 100000000);
  }
  void configure(const PluginContext& ctx) override {
    if (features_.empty()) throw ParamError("features", "is empty; name at least one grid layer");
    if (out_path_.empty() || out_path_.back() == '/')
      throw ParamError("model", "'" + out_path_ +
                                    "' is not a file name; expected the model file to write, "
                                    "e.g. model.yaml (relative to the output folder)");
    if (min_sigma_.empty() || (min_sigma_.size() > 1 && min_sigma_.size() != features_.size()))
      throw ParamError("min_sigma", "give one value, or one per feature (" +
                                        std::to_string(features_.size()) + ")");
    // A feature constant in a class's cells would otherwise be written as sigma: 0, a model
    // that potts_gaussian refuses only at the next run.
    for (std::size_t f = 0; f < min_sigma_.size(); ++f)
      if (!(min_sigma_[f] > 0))
        throw ParamError("min_sigma", "floors must be > 0 (entry " + std::to_string(f + 1) +
                                          " is " + numberText(min_sigma_[f]) +
                                          "): a class whose cells all share one value would "
                                          "get sigma 0, which no model can use");
    // Without an obstacle class the rule would be skipped while the model's provenance says it
    // was applied.
    if (obstacle_rule_ && ctx.labels && ctx.labels->obstacle() < 0)
      throw ParamError("obstacle_rule",
                       "the label set has no class 'obstacle' for the rule to "
                       "make; name one in labels:, or set it false");
    // How each feature was computed goes into the model, so an energy using it can check that
    // its stages compute the same (potts_gaussian: check_feature_origins).
    origins_.clear();
    if (ctx.layer_origins)
      for (const auto& f : features_)
        if (const auto it = ctx.layer_origins->find(f); it != ctx.layer_origins->end())
          origins_.emplace_back(f, it->second);
  }
  std::vector<std::string> reads() const override { return features_; }

  void begin(const RunInfo& info) override {
    info_ = info;
    // Said before the first frame: at the end every frame's statistics would be lost.
    if (std::filesystem::is_directory(modelPath()))
      throw std::runtime_error("output '" + name() + "': parameter 'model': '" + modelPath() +
                               "' is a folder; expected a model file name");
    const std::size_t K = info.labels->size(), F = features_.size();
    n_.assign(K * F, 0);
    mean_.assign(K * F, 0);
    m2_.assign(K * F, 0);
    samples_.assign(K * F, ReservoirSample(1, max_cells_));
    cells_.assign(K, ReservoirSample(F, max_cells_));
    robust_ = estimator_ == "robust";
    obstacle_ = static_cast<std::size_t>(std::max(0, info.labels->obstacle()));
    frames_ = 0;
  }

  void write(const FrameContext& ctx) override {
    const Frame& fr = *ctx.frame;
    const TerrainGrid& g = *ctx.grid;
    if (fr.truth.label.size() != fr.points.size()) return;  // unlabelled frame
    ++frames_;
    const std::size_t K = info_.labels->size(), F = features_.size();
    std::vector<const float*> layers(F);
    for (std::size_t f = 0; f < F; ++f) layers[f] = g.layer(features_[f]).data();
    std::vector<uint32_t> count(K);
    for (int c = 0, n = static_cast<int>(g.cells()); c < n; ++c) {
      std::fill(count.begin(), count.end(), 0);
      uint32_t labelled = 0;
      for (const uint32_t* it = g.pointsBegin(c); it != g.pointsEnd(c); ++it) {
        const LabelId l = fr.truth.label[*it];
        if (l == labels::kUnknown || l >= K) continue;
        ++count[l];
        ++labelled;
      }
      if (labelled < static_cast<uint32_t>(min_points_)) continue;
      std::size_t best = 1;
      bool tied = false;
      for (std::size_t k = 2; k < K; ++k) {
        if (count[k] > count[best])
          best = k, tied = false;
        else if (count[k] == count[best])
          tied = true;
      }
      const bool obstacle_cell = obstacle_rule_ && obstacle_ > 0 && count[obstacle_] > 0;
      if (obstacle_cell) best = obstacle_;
      // At min_purity 0.5 two classes can both reach it: such a cell is no sample of either
      // (it would have gone to the lower id).
      else if (tied || count[best] < min_purity_ * labelled)
        continue;
      bool any_value = false;
      for (std::size_t f = 0; f < F; ++f) any_value |= !std::isnan(layers[f][c]);
      if (!any_value) continue;  // no feature measured here: nothing to learn, no mixture weight
      if (components_ > 1) {
        record_.resize(F);
        for (std::size_t f = 0; f < F; ++f) record_[f] = layers[f][c];
        cells_[best].push(record_.data());
      }
      for (std::size_t f = 0; f < F; ++f) {
        const float v = layers[f][c];
        if (std::isnan(v)) continue;
        // Welford's update: stable for millions of cells.
        const std::size_t i = best * F + f;
        if (robust_) samples_[i].push(v);
        ++n_[i];
        const double d = v - mean_[i];
        mean_[i] += d / n_[i];
        m2_[i] += d * (v - mean_[i]);
      }
    }
  }

  void end(const RunSummary& summary) override {
    std::ostringstream o;   // the classes; the header, which reports on them, goes before
    std::string unsettled;  // classes whose mixture EM did not settle
    const std::size_t K = info_.labels->size(), F = features_.size();
    // A model without classes would replace a good one and fail only when an energy loads it.
    if (frames_ == 0)
      throw std::runtime_error(
          "no labelled frame reached it (" + std::to_string(summary.frames_ok) +
          " frame(s) ok, none with ground-truth labels: a source without labels, or every frame "
          "failed); nothing learnt, " +
          modelPath() + " left as it was");
    checkEveryFeatureMeasured(K, F);
    bool any_class = false;
    for (std::size_t i = F; i < K * F; ++i) any_class = any_class || n_[i] >= 2;
    if (!any_class)
      throw std::runtime_error("no class has 2 or more training cells in " +
                               std::to_string(frames_) +
                               " labelled frame(s) (cells need >= " + std::to_string(min_points_) +
                               " labelled points and purity >= " + numberText(min_purity_) +
                               "); nothing learnt, " + modelPath() + " left as it was");
    // Numbers as the shortest text that reads back exactly: six digits lost 0.12345679 to
    // 0.123457, so a model loaded from its file was not the one learnt.
    for (std::size_t k = 1; k < K; ++k) {
      std::ostringstream cls;
      bool any = false;
      std::vector<Gaussian> single(F);
      std::vector<bool> learnt(F, false);
      for (std::size_t f = 0; f < F; ++f) {
        const std::size_t i = k * F + f;
        if (n_[i] < 2) continue;
        any = learnt[f] = true;
        double mean = mean_[i], sigma = std::sqrt(m2_[i] / (n_[i] - 1));
        if (robust_) robustEstimate(samples_[i].values(), mean, sigma);
        single[f] = {mean, std::max(sigmaFloor(f), sigma)};
        cls << "    " << features_[f] << ": {mean: " << numberText(single[f].mean)
            << ", sigma: " << numberText(single[f].sigma) << "}  # " << n_[i] << " cells\n";
      }
      if (!any) continue;
      o << "  " << info_.labels->name(static_cast<LabelId>(k)) << ":\n";
      bool converged = true;
      const std::vector<Component> mix =
          components_ > 1 ? mixture(cells_[k].values(), single, learnt, &converged)
                          : std::vector<Component>{};
      if (mix.size() < 2) {
        o << cls.str();
        continue;
      }
      if (!converged)
        unsettled += (unsettled.empty() ? "" : ", ") + info_.labels->name(static_cast<LabelId>(k));
      o << "    components:  # " << cells_[k].size() << " cells"
        << (cells_[k].thinned() ? " (a uniform sample of " + std::to_string(cells_[k].seen()) + ")"
                                : std::string())
        << ", classification EM"
        << (converged ? "" : " (unsettled after 100 rounds: the assignment of lowest energy)")
        << "\n";
      for (const Component& m : mix) {
        o << "      - weight: " << numberText(m.weight) << "  # " << m.cells << " cells\n"
          << "        features:\n";
        for (std::size_t f = 0; f < F; ++f)
          if (learnt[f])
            o << "          " << features_[f] << ": {mean: " << numberText(m.g[f].mean)
              << ", sigma: " << numberText(m.g[f].sigma) << "}\n";
      }
    }
    std::ostringstream head;
    head << "# Per-class Gaussian feature model (paper 000 §4.6), learnt by the feature_stats "
            "output.\n";
    head << "provenance: \"config " << info_.config_path << ", " << frames_
         << " labelled frame(s), cells with purity >= " << min_purity_ << " and >= " << min_points_
         << " labelled points"
         << (obstacle_rule_ ? ", any obstacle point makes an obstacle cell" : "") << ", "
         << estimator_ << " estimates, sigma floors " << floorsText()
         << (components_ > 1 ? ", up to " + std::to_string(components_) + " Gaussians per class"
                             : "")
         << (thinned() ? ", robust estimates and mixtures from a uniform sample of at most " +
                             std::to_string(max_cells_) + " cells per class"
                       : std::string())
         << (unsettled.empty() ? ""
                               : ", mixture EM did not settle in 100 rounds for " + unsettled +
                                     " (the assignment of lowest energy seen is kept)")
         << "\"\n";
    if (!origins_.empty()) {
      head << "feature_origins:  # how each feature was computed: stage, parameters, inputs\n";
      for (const auto& [f, text] : origins_) head << "  " << f << ": " << text << "\n";
    }
    head << "classes:\n";
    writeFileAtomic(modelPath(), head.str() + o.str());
  }

  /// The model when it lies in the run's output folder: an earlier run's must not pass for this
  /// run's should it stop early. One given elsewhere (configs/models/x.yaml) is the user's file,
  /// kept until this run replaces it.
  std::vector<std::string> summaryFiles() const override {
    const std::filesystem::path p = std::filesystem::path(out_path_).lexically_normal();
    if (p.is_absolute() || p.empty() || *p.begin() == "..") return {};
    return {out_path_};
  }

 private:
  std::vector<std::pair<std::string, std::string>> origins_;  ///< feature -> flow YAML
  struct Gaussian {
    double mean = 0, sigma = 1;
  };
  struct Component {
    double weight = 0;
    std::size_t cells = 0;
    std::vector<Gaussian> g;  ///< per feature
  };

  /// A class learnt without one of the features would give a model the energy stage refuses
  /// ("not in model for class …"), which hides the cause: the feature was NaN in every training
  /// cell of that class. Say so here, before any model is written.
  void checkEveryFeatureMeasured(std::size_t K, std::size_t F) const {
    std::string missing;
    for (std::size_t k = 1; k < K; ++k) {
      std::size_t cells = 0;
      for (std::size_t f = 0; f < F; ++f) cells = std::max(cells, n_[k * F + f]);
      if (cells < 2) continue;  // class absent from the training data: left out of the model
      for (std::size_t f = 0; f < F; ++f)
        if (n_[k * F + f] < 2)
          missing += std::string(missing.empty() ? "" : "; ") + "class '" +
                     info_.labels->name(static_cast<LabelId>(k)) + "' has a value of feature '" +
                     features_[f] + "' in " + std::to_string(n_[k * F + f]) + " of its " +
                     std::to_string(cells) + " training cells";
    }
    if (!missing.empty())
      throw std::runtime_error(
          "cannot learn the model: " + missing +
          " (at least 2 needed). The feature is NaN (no data) there: not measured by this data, "
          "e.g. the intensity of scans that store none (Open3D-ML's SemanticKITTI) or a camera "
          "feature of a class never seen by a camera. Train on data that has it, or drop it "
          "from the feature list");
  }

  /// Whether a class had more cells than max_sample_cells, so that some estimate saw a sample.
  bool thinned() const {
    for (const ReservoirSample& x : samples_)
      if (x.thinned()) return true;
    for (const ReservoirSample& x : cells_)
      if (x.thinned()) return true;
    return false;
  }

  /// "height_diff 0.02, roughness 0.005": the floors as applied, for the provenance.
  std::string floorsText() const {
    std::ostringstream t;
    for (std::size_t f = 0; f < features_.size(); ++f)
      t << (f ? ", " : "") << features_[f] << " " << numberText(sigmaFloor(f));
    return t.str();
  }

  std::string modelPath() const {
    return out_path_.front() == '/' ? out_path_ : info_.output_dir + "/" + out_path_;
  }

  double sigmaFloor(std::size_t f) const { return min_sigma_[min_sigma_.size() == 1 ? 0 : f]; }

  /// Classification EM over one class's cells (`x`: cells × F, NaN = no data). Starts from equal
  /// shares of the cells ordered by the first feature, then alternates: estimate each component
  /// from its cells (as the single model would: `estimator`, σ floors; a feature without values
  /// in a component takes the class's single estimate) and move each cell to the component under
  /// which it is most likely. Components under 10 cells are dropped. Deterministic. Stops when
  /// no cell moves (`*converged`) or after 100 rounds, then with the assignment of lowest
  /// energy seen; either way the estimates are those of the assignment returned.
  std::vector<Component> mixture(const std::vector<float>& x, const std::vector<Gaussian>& single,
                                 const std::vector<bool>& learnt, bool* converged) const {
    const std::size_t F = features_.size(), n = x.size() / F;
    constexpr std::size_t kMinCells = 10;
    constexpr int kMaxRounds = 100;
    int M = components_;
    if (n < kMinCells * 2) return {};
    std::vector<std::size_t> order(n);
    for (std::size_t i = 0; i < n; ++i) order[i] = i;
    auto key = [&](std::size_t i) {
      const float v = x[i * F];
      return std::isnan(v) ? single[0].mean : static_cast<double>(v);
    };
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return key(a) < key(b); });
    std::vector<int> z(n);
    for (std::size_t r = 0; r < n; ++r) z[order[r]] = static_cast<int>(r * M / n);
    std::vector<Component> comp;
    std::vector<float> vals;
    // Estimates of each component from its cells, as the single model would make them.
    auto mStep = [&]() {
      comp.assign(M, {});
      for (int m = 0; m < M; ++m) {
        comp[m].g = single;
        for (std::size_t i = 0; i < n; ++i) comp[m].cells += z[i] == m;
        comp[m].weight = static_cast<double>(comp[m].cells) / n;
        for (std::size_t f = 0; f < F; ++f) {
          if (!learnt[f]) continue;
          vals.clear();
          for (std::size_t i = 0; i < n; ++i)
            if (z[i] == m && !std::isnan(x[i * F + f])) vals.push_back(x[i * F + f]);
          if (vals.size() < 2) continue;
          double mean = 0, sigma = 0;
          if (robust_) {
            robustEstimate(vals, mean, sigma);
          } else {
            for (float v : vals) mean += v;
            mean /= vals.size();
            for (float v : vals) sigma += (v - mean) * (v - mean);
            sigma = std::sqrt(sigma / (vals.size() - 1));
          }
          comp[m].g[f] = {mean, std::max(sigmaFloor(f), sigma)};
        }
      }
    };
    *converged = false;
    double best_energy = INFINITY;
    std::vector<int> best_z;
    for (int iter = 0; iter < kMaxRounds; ++iter) {
      mStep();
      // Drop components too small to estimate; their cells move in the next assignment.
      std::vector<Component> kept;
      for (auto& c : comp)
        if (c.cells >= kMinCells) kept.push_back(std::move(c));
      const bool dropped = static_cast<int>(kept.size()) < M;
      comp = std::move(kept);
      M = static_cast<int>(comp.size());
      if (M < 2) return {};
      // Assignment step: the most likely component (log weight + log likelihood). On the way,
      // the energy of the assignment the estimates came from (the classification likelihood
      // of z and its estimates), unless components were just dropped (z names old ones).
      bool changed = dropped;
      double energy = 0;
      std::vector<int> previous = z;
      for (std::size_t i = 0; i < n; ++i) {
        int best = 0;
        double best_e = INFINITY;
        for (int m = 0; m < M; ++m) {
          double e = -std::log(comp[m].weight);
          for (std::size_t f = 0; f < F; ++f) {
            const float v = x[i * F + f];
            if (!learnt[f] || std::isnan(v)) continue;
            const Gaussian& g = comp[m].g[f];
            e += (v - g.mean) * (v - g.mean) / (2 * g.sigma * g.sigma) + std::log(g.sigma);
          }
          if (e < best_e) best_e = e, best = m;
          if (!dropped && m == z[i]) energy += e;
        }
        changed |= z[i] != best;
        z[i] = best;
      }
      if (!dropped && energy < best_energy) best_energy = energy, best_z = std::move(previous);
      if (!changed) {
        *converged = true;
        break;
      }
    }
    // With the robust estimator hard EM is not monotone and can cycle: unsettled, it keeps the
    // assignment of lowest energy seen. Estimates, weights and counts are of the assignment kept.
    if (!*converged && !best_z.empty()) {
      z = best_z;
      M = 1 + *std::max_element(z.begin(), z.end());
    }
    mStep();
    std::vector<Component> out;
    for (auto& c : comp)
      if (c.cells >= kMinCells) out.push_back(c);
    if (out.size() < comp.size()) {  // renormalise over the components kept
      std::size_t kept_cells = 0;
      for (const auto& c : out) kept_cells += c.cells;
      for (auto& c : out) c.weight = double(c.cells) / double(kept_cells);
    }
    return out.size() < 2 ? std::vector<Component>{} : out;
  }

  // Median and 1.4826·MAD: σ of a Gaussian core, unaffected by up to half of outliers. Of an
  // even count it takes the upper of the two middle values (a median all the same: it minimises
  // the absolute deviations as well as their mean does); the shipped models were learnt so.
  static void robustEstimate(std::vector<float>& v, double& mean, double& sigma) {
    auto median = [](std::vector<float>& x) {
      auto mid = x.begin() + x.size() / 2;
      std::nth_element(x.begin(), mid, x.end());
      return static_cast<double>(*mid);
    };
    mean = median(v);
    for (float& x : v) x = static_cast<float>(std::abs(x - mean));
    sigma = 1.4826 * median(v);
  }

  std::vector<std::string> features_;
  std::string out_path_ = "model.yaml";
  double min_purity_ = 0.9;
  int min_points_ = 3;
  std::vector<double> min_sigma_ = {1e-4};
  RunInfo info_;
  std::vector<uint64_t> n_;
  std::vector<double> mean_, m2_;
  std::string estimator_ = "moments";
  bool obstacle_rule_ = false;
  bool robust_ = false;
  std::size_t obstacle_ = 0;
  std::vector<ReservoirSample> samples_;
  int components_ = 1;
  std::vector<ReservoirSample> cells_;  ///< per class: cells × features (components > 1)
  std::vector<float> record_;           ///< one cell's features, on its way into cells_
  int max_cells_ = 1 << 20;
  std::size_t frames_ = 0;
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::FeatureStats, terramrf::PluginKind::kOutput, "feature_stats",
                "learns per-class feature mean/σ from annotated cells and writes a model file "
                "for potts_gaussian (paper 000 §4.6)")
