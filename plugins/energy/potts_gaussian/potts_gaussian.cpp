// The energy of paper 000 eq. 10–12: a Potts-style neighbour term over the 8-neighbourhood
// weighted by β, and a Gaussian feature term weighted by α.
//
// Sign of δ: eq. 10 as printed gives −1 to different and +1 to equal labels, which, minimised,
// would reward label changes everywhere; the model it cites (Deng et al.) and every result in the
// paper need the opposite, so δ(equal) = −1 and δ(different) = +1 here (docs/energy.md).
//
// A class of the model file may also be a mixture of Gaussians (feature_stats `components`); its
// feature energy is then −log Σ_m w_m exp(−E_m), E_m being eq. 11 under component m.
//
// Evidence layers are the slot for what a later stage knows besides this scan's features (paper
// 000 §4.7: the previous classification, carried over by egomotion, fills data gaps): one cost
// per class, added to the unary where given. A cell without points but with evidence is then
// classified instead of left unknown.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>

#include "feature_origins.hpp"
#include "gaussian_model.hpp"
#include "terramrf/errors.hpp"
#include "terramrf/plugin.hpp"

namespace terramrf {

class PottsGaussian final : public Stage {
 public:
  void declare(ParamDecl& d) override {
    d.add("model", model_path_, "per-class feature model file (YAML: classes → feature → {mean, sigma})")
        .required().existingPath();
    d.add("features", features_,
          "grid layers used as features; each must be in the model for every class")
        .required()
        .unique();
    d.add("classes", classes_param_,
          "labels the optimiser may assign (names from the label set); empty = every class of the "
          "label set but 'unknown', in id order (road, rough, obstacle with the default set)")
        .unique();
    d.add("alpha", alpha_, "weight α of the feature energy (eq. 12)").unit("1").range(0, 1e6);
    d.add("beta", beta_, "Potts weight β of the 4 edge neighbours (eq. 10)").unit("1").range(0, 1e6);
    d.add("beta_diagonal", beta_diagonal_,
          "Potts weight of the 4 corner neighbours; negative = same as beta (paper 000 uses one β)")
        .unit("1").range(-1, 1e6);
    d.add("preclass_layer", preclass_layer_,
          "pre-class layer (0 unknown, 1 flat, 2 obstacle) used for the initial labelling; '' = none");
    d.add("class_cost", class_cost_,
          "constant cost_k per class, in the order of `classes` (empty = all 0), added to the "
          "unary after the alpha weighting: unary_k = alpha·E_f + cost_k, E = Σ unary + pairs. "
          "A negative log prior, or the price of missing a class — a negative obstacle cost "
          "trades false alarms for obstacle recall (docs/energy.md)")
        .unit("energy")
        .range(-1e6, 1e6);
    d.add("min_points", min_points_, "cells with fewer points are fixed to unknown (no data)")
        .unit("points").range(1, 1000);
    d.add("evidence_layers", evidence_layers_,
          "grid layers, one per class of `classes` in its order, each an energy added to that "
          "class's unary where the cell has a value (e.g. −log of the probability an earlier "
          "classification gives it); NaN in any of them = no evidence for that cell. A cell with "
          "fewer than min_points points but with evidence is classified from the evidence and "
          "its neighbours instead of fixed to unknown (temporal fusion, docs/energy.md)")
        .unit("energy");
    d.add("check_feature_origins", check_origins_,
          "refuse a model whose features were computed otherwise (another stage, parameter or "
          "input) than the stages before this one compute them, as the model records it; false "
          "uses it anyway (models that record nothing are not checked)");
  }

  void configure(const PluginContext& ctx) override {
    try {
      model_ = GaussianModel::load(model_path_);
    } catch (const std::exception& e) {
      throw ParamError("model", e.what());
    }
    if (features_.empty()) throw ParamError("features", "list at least one feature layer");
    // A fixed default list would leave the extra classes of a config's own label set
    // unpredicted without a word, so the default follows the label set.
    classes_ = classes_param_;
    if (classes_.empty())
      for (std::size_t id = 1; id < ctx.labels->size(); ++id)
        classes_.push_back(ctx.labels->name(static_cast<LabelId>(id)));
    if (!class_cost_.empty() && class_cost_.size() != classes_.size())
      throw ParamError("class_cost", "give one value per class of `classes` (" +
                                         std::to_string(classes_.size()) + "), or none");
    if (!evidence_layers_.empty() && evidence_layers_.size() != classes_.size())
      throw ParamError("evidence_layers", "give one layer per class of `classes` (" +
                                              std::to_string(classes_.size()) +
                                              ", in its order: " + joined(classes_) + "), or none");
    active_.clear();
    obstacle_index_ = -1;
    for (const auto& c : classes_) {
      const int id = ctx.labels->find(c);
      if (id <= 0)
        throw ParamError("classes",
                         "'" + c + "' is not a class of the label set (or is 'unknown')");
      if (c == "obstacle") obstacle_index_ = static_cast<int>(active_.size());
      active_.push_back(static_cast<LabelId>(id));
      auto it = model_.classes.find(c);
      if (it == model_.classes.end())
        throw ParamError("model", model_path_ + " has no entry for class '" + c +
                                      "' (a model holds the classes its training cells showed); "
                                      "train on data that shows it, or leave it out of `classes`");
      for (std::size_t j = 0; j < it->second.size(); ++j)
        for (const auto& f : features_)
          if (!it->second[j].features.count(f))
            throw ParamError(
                "features",
                "feature '" + f + "' is not in model " + model_path_ + " for class '" + c + "'" +
                    (it->second.size() > 1 ? " (component " + std::to_string(j + 1) + ")" : "") +
                    " (the model was made for other features)");
    }
    if (check_origins_ && ctx.layer_origins) checkFeatureOrigins(*ctx.layer_origins);
    // Per frame, only the features whose origins the run did not know here (a live stream's
    // received layers): a known one was checked above, and a stage may have rewritten a
    // received layer, whose origin a frame would then still give as the sender's.
    frame_checked_.clear();
    for (const auto& f : features_)
      if (!ctx.layer_origins || !ctx.layer_origins->count(f)) frame_checked_.push_back(f);
    cost_.assign(active_.size(), 0.f);
    for (std::size_t k = 0; k < class_cost_.size(); ++k) cost_[k] = static_cast<float>(class_cost_[k]);
    // Precompute per class, component and feature: 1/(2σ²), log(√(2π)σ), and −log(weight).
    const std::size_t K = active_.size(), F = features_.size();
    comp_begin_.assign(1, 0);
    mean_.clear();
    inv2var_.clear();
    lognorm_.clear();
    neglogw_.clear();
    for (std::size_t k = 0; k < K; ++k) {
      for (const GaussianComponent& comp : model_.classes.at(classes_[k])) {
        neglogw_.push_back(static_cast<float>(-std::log(comp.weight)));
        for (std::size_t f = 0; f < F; ++f) {
          const Gaussian& g = comp.features.at(features_[f]);
          // The loader checks the model in double; the unaries are single precision, where
          // σ < 4e-20 gives 1/(2σ²) = inf and a feature equal to the mean then NaN.
          if (!(std::abs(g.mean) <= 3e38) || !(g.sigma >= 1e-18 && g.sigma <= 1e18))
            throw ParamError("model", model_path_ + ": " + classes_[k] + "." + features_[f] +
                                          ": mean " + numberText(g.mean) + ", sigma " +
                                          numberText(g.sigma) +
                                          " cannot be computed with in single precision; "
                                          "expected |mean| < 3e38 and sigma in [1e-18, 1e18]");
          mean_.push_back(static_cast<float>(g.mean));
          inv2var_.push_back(static_cast<float>(1.0 / (2 * g.sigma * g.sigma)));
          lognorm_.push_back(static_cast<float>(std::log(std::sqrt(2 * M_PI) * g.sigma)));
        }
      }
      comp_begin_.push_back(static_cast<int>(neglogw_.size()));
    }
    comp_energy_.resize(neglogw_.size());
  }

  std::vector<std::string> reads() const override {
    std::vector<std::string> r = features_;
    r.push_back(artefacts::kPoints);
    if (!preclass_layer_.empty()) r.push_back(preclass_layer_);
    r.insert(r.end(), evidence_layers_.begin(), evidence_layers_.end());
    return r;
  }
  std::vector<std::string> writes() const override { return {artefacts::kEnergy}; }

  void process(FrameContext& ctx) override {
    if (check_origins_ && ctx.frame && !ctx.frame->layer_origins.empty())
      checkFrameOrigins(*ctx.frame);
    TerrainGrid& g = *ctx.grid;
    EnergyModel& em = ctx.energy;
    const int K = static_cast<int>(active_.size());
    const std::size_t F = features_.size();
    em.resize(g.rows(), g.cols(), K);
    em.active = active_;
    em.beta = static_cast<float>(beta_);
    em.beta_diagonal = static_cast<float>(beta_diagonal_ < 0 ? beta_ : beta_diagonal_);
    std::vector<const float*> feat(F);
    for (std::size_t f = 0; f < F; ++f) feat[f] = g.layer(features_[f]).data();
    const float* pre = preclass_layer_.empty() ? nullptr : g.layer(preclass_layer_).data();
    std::vector<const float*> ev(evidence_layers_.size());
    for (std::size_t k = 0; k < ev.size(); ++k) ev[k] = g.layer(evidence_layers_[k]).data();
    const float alpha = static_cast<float>(alpha_);
    std::size_t from_evidence = 0;  // cells without points classified from evidence alone
    for (int c = 0, n = static_cast<int>(g.cells()); c < n; ++c) {
      const bool has_points = g.count(c) >= static_cast<uint32_t>(min_points_);
      const bool has_evidence = !ev.empty() && evidenceAt(ev, c, g);
      float* u = &em.unary[std::size_t(c) * K];
      if (!has_points) {
        if (!has_evidence) {
          em.fixed[c] = 1;
          continue;
        }
        // No data of this scan: the evidence alone, with its neighbours, decides.
        int best = 0;
        for (int k = 0; k < K; ++k) {
          u[k] = cost_[k] + ev[k][c];
          if (u[k] < u[best]) best = k;
        }
        em.initial[c] = static_cast<uint8_t>(best);
        ++from_evidence;
        continue;
      }
      for (int k = 0; k < K; ++k) {
        // Eq. 11 per component; a mixture's energy is −log Σ_m w_m exp(−E_m) (log-sum-exp).
        // A feature that is NaN here (no data) does not vote, in any component.
        const int b = comp_begin_[k], e = comp_begin_[k + 1];
        float emin = INFINITY;
        for (int j = b; j < e; ++j) {
          float ej = neglogw_[j];
          for (std::size_t f = 0; f < F; ++f) {
            const float v = feat[f][c];
            if (std::isnan(v)) continue;
            const float d = v - mean_[j * F + f];
            ej += d * d * inv2var_[j * F + f] + lognorm_[j * F + f];
          }
          comp_energy_[j] = ej;
          emin = std::min(emin, ej);
        }
        float energy = emin;
        if (e - b > 1) {
          float sum = 0;
          for (int j = b; j < e; ++j) sum += std::exp(emin - comp_energy_[j]);
          energy = emin - std::log(sum);
        }
        // A feature 1e20 σ from every component's mean overflows to inf (and α = 0 would make
        // that NaN); optimisers need finite differences, and "as unlikely as can be" orders the
        // classes the same way.
        if (!(energy <= kMaxFeatureEnergy)) energy = kMaxFeatureEnergy;
        u[k] = alpha * energy + cost_[k] + (has_evidence ? ev[k][c] : 0.f);
      }
      // Initial labelling: the pre-classification decides obstacle vs flat; among the others
      // the feature term decides.
      int best = 0;
      const bool pre_obstacle = pre && pre[c] == 2.f && obstacle_index_ >= 0;
      const bool pre_flat = pre && pre[c] == 1.f;
      if (pre_obstacle) {
        best = obstacle_index_;
      } else {
        float bu = INFINITY;
        for (int k = 0; k < K; ++k) {
          if (pre_flat && k == obstacle_index_ && K > 1) continue;
          if (u[k] < bu) bu = u[k], best = k;
        }
      }
      em.initial[c] = static_cast<uint8_t>(best);
    }
    if (!ev.empty()) ctx.metrics[name() + ".cells_from_evidence"] = double(from_evidence);
  }

 private:
  /// True if every evidence layer holds a number at cell c. NaN in any = no evidence; an
  /// infinite cost would make the optimisers' energy differences NaN, so it is the producing
  /// stage's error, named here.
  bool evidenceAt(const std::vector<const float*>& ev, int c, const TerrainGrid& g) const {
    bool all = true;
    for (std::size_t k = 0; k < ev.size(); ++k) {
      const float v = ev[k][c];
      if (std::isnan(v)) {
        all = false;
      } else if (std::isinf(v)) {
        const Eigen::Vector2d at = g.geometry().cellCentre(c / g.cols(), c % g.cols());
        char where[96];
        std::snprintf(where, sizeof where, "cell (row %d, col %d) at x = %.2f m, y = %.2f m",
                      c / g.cols(), c % g.cols(), at.x(), at.y());
        throw std::runtime_error("evidence layer '" + evidence_layers_[k] + "' holds " +
                                 (v > 0 ? "+inf" : "-inf") + " in " + where +
                                 "; expected a finite energy, or NaN for no evidence");
      }
    }
    return all;
  }

  static std::string joined(const std::vector<std::string>& v) {
    std::string s;
    for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
    return s;
  }

  void checkFeatureOrigins(const std::map<std::string, std::string>& here) const {
    std::string why;
    for (const auto& f : features_) {
      const auto learnt = model_.feature_origins.find(f);
      const auto now = here.find(f);
      if (learnt == model_.feature_origins.end() || now == here.end()) continue;
      for (const auto& d : originDifferences(learnt->second, now->second))
        why += "\n    feature '" + f + "': " + d;
    }
    if (!why.empty())
      throw ParamError("model", model_path_ +
                                    " was learnt on features computed otherwise than here:" + why +
                                    "\n    retrain it with these stages, or give them the model's "
                                    "parameters (check_feature_origins: false uses it anyway)");
  }

  /// Layers that came with the frame computed elsewhere, with their origins (a live stream's,
  /// unknown at configure()): the frame fails if its features were computed otherwise than the
  /// model's.
  void checkFrameOrigins(const Frame& f) const {
    std::string why;
    for (const auto& feat : frame_checked_) {
      const auto learnt = model_.feature_origins.find(feat);
      const auto got = f.layer_origins.find(feat);
      if (learnt == model_.feature_origins.end() || got == f.layer_origins.end() ||
          learnt->second == got->second)
        continue;
      for (const auto& d : originDifferences(learnt->second, got->second))
        why += "\n    feature '" + feat + "': " + d;
    }
    if (!why.empty())
      throw InputError(f.source_path,
                       "scan '" + f.id +
                           "': its layers came computed otherwise "
                           "than model " +
                           model_path_ +
                           " was learnt on (\"here\": "
                           "as the sender computed them):" +
                           why +
                           "\n    run the sender with the model's stages, or retrain "
                           "(check_feature_origins: false uses it anyway)");
  }

  /// Cap of eq. 11's energy per cell and class: finite, and far above any sum of real terms.
  static constexpr float kMaxFeatureEnergy = 1e20f;

  std::string model_path_;
  std::vector<std::string> features_;
  std::vector<std::string> frame_checked_;  ///< features whose origins each frame may bring
  std::vector<std::string> classes_param_;  ///< as configured; empty = the label set's classes
  std::vector<std::string> classes_;        ///< the classes in use, in unary order
  double alpha_ = 1.0;
  double beta_ = 0.8;  // paper 000 §5: β = 0.8 in all experiments
  double beta_diagonal_ = -1;
  std::string preclass_layer_ = "";
  bool check_origins_ = true;
  int min_points_ = 1;
  std::vector<double> class_cost_;
  std::vector<std::string> evidence_layers_;

  GaussianModel model_;
  std::vector<LabelId> active_;
  int obstacle_index_ = -1;
  std::vector<int> comp_begin_;  ///< components of class k: [comp_begin_[k], comp_begin_[k + 1])
  std::vector<float> mean_, inv2var_, lognorm_, neglogw_, cost_, comp_energy_;
};

}  // namespace terramrf

TERRAMRF_PLUGIN(terramrf::PottsGaussian, terramrf::PluginKind::kEnergy, "potts_gaussian",
                "MRF energy of paper 000 eq. 10-12: Potts neighbour term (beta) + Gaussian "
                "feature term (alpha)")
