#include "terramrf/roc.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <sstream>

#include "terramrf/errors.hpp"
#include "terramrf/padded_labels.hpp"
#include "terramrf/plugin.hpp"
#include "terramrf/text_format.hpp"

namespace terramrf {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string num(double v, const char* fmt = "%.6g") {
  if (std::isnan(v)) return "";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char b[48];
  std::snprintf(b, sizeof b, fmt, v);
  return b;
}
std::string jsonNum(double v) {
  if (!std::isfinite(v)) return "null";
  return num(v, "%.6g");
}
std::string xmlEscape(const std::string& s) {
  std::string o;
  for (char ch : s) {
    switch (ch) {
      case '&':
        o += "&amp;";
        break;
      case '<':
        o += "&lt;";
        break;
      case '>':
        o += "&gt;";
        break;
      case '"':
        o += "&quot;";
        break;
      default:
        o += ch;
    }
  }
  return o;
}
}  // namespace

const char* toString(ScoreSource s) {
  switch (s) {
    case ScoreSource::kNone:
      return "none";
    case ScoreSource::kScoreLayers:
      return "score_layers";
    case ScoreSource::kLocalEnergy:
      return "local_energy";
  }
  return "?";
}

std::vector<const Layer*> scoreLayers(const TerrainGrid& grid, const LabelSet& labels) {
  std::vector<const Layer*> out(labels.size(), nullptr);
  for (std::size_t c = 1; c < labels.size(); ++c) {
    const std::string name = layers::score(labels.name(static_cast<LabelId>(c)));
    if (grid.has(name)) out[c] = &grid.layer(name);
  }
  return out;
}

namespace {

/// localEnergyScores' margins from padded label indices (see there); KK > 0 fixes K.
template <int KK>
void marginScores(const EnergyModel& em, const PaddedLabels& pad, std::size_t num_classes,
                  std::vector<Layer>& out) {
  const int K = KK > 0 ? KK : em.numLabels();
  const int W = pad.stride();
  const std::ptrdiff_t off[8] = {-W - 1, -W, -W + 1, -1, 1, W - 1, W, W + 1};
  const double wd = em.beta_diagonal, wb = em.beta;
  const double w[8] = {wd, wb, wd, wb, wb, wd, wb, wd};
  // A local array for a fixed K stays in registers; through a pointer to the heap every update
  // goes through memory, where narrow stores followed by wide loads stall store forwarding.
  double e_fixed[KK > 0 ? KK : 1];
  std::vector<double> e_store(KK > 0 ? 0 : K);
  double* e = KK > 0 ? e_fixed : e_store.data();
  for (int r = 0; r < em.rows; ++r) {
    const uint8_t* p = pad.at(r, 0);
    for (int c = 0; c < em.cols; ++c, ++p) {
      if (*p >= K) continue;  // fixed, or a label that is not active
      const std::size_t i = std::size_t(r) * em.cols + c;
      // EnergyModel::localEnergy for every k at once, each sum in the same order.
      for (int k = 0; k < K; ++k) e[k] = em.unary[i * K + k];
      for (int d = 0; d < 8; ++d) {
        const int l = p[off[d]];
        if (l == K) continue;
        for (int k = 0; k < K; ++k) e[k] += l == k ? -w[d] : w[d];
      }
      for (int k = 0; k < K; ++k) {
        if (em.active[k] >= num_classes) continue;
        double other = std::numeric_limits<double>::infinity();
        for (int j = 0; j < K; ++j)
          if (j != k) other = std::min(other, e[j]);
        out[em.active[k]][i] = K == 1 ? 0.f : static_cast<float>(other - e[k]);
      }
    }
  }
}

}  // namespace

std::vector<Layer> localEnergyScores(const EnergyModel& em, const std::vector<LabelId>& labels,
                                     std::size_t num_classes) {
  const int K = em.numLabels();
  if (K == 0 || K > 254 || em.cells() != labels.size() || em.unary.size() != em.cells() * K)
    return {};
  // Grid labels → active label indices; a cell whose label is not active keeps no score, and as
  // a neighbour it counts as "different" for every k: it gets K + 1, which no k equals. The pad
  // and the fixed cells hold K and are skipped.
  std::vector<int> index_of(256, -1);
  for (int k = 0; k < K; ++k) index_of[em.active[k]] = k;
  std::vector<uint8_t> lab(em.cells(), 0);
  for (std::size_t i = 0; i < em.cells(); ++i) {
    const int k = em.fixed[i] ? K : index_of[labels[i]];
    lab[i] = static_cast<uint8_t>(k < 0 ? K + 1 : k);
  }
  PaddedLabels pad;
  pad.assign(em, lab);
  std::vector<Layer> out(num_classes);
  for (int k = 0; k < K; ++k)
    if (em.active[k] < num_classes) out[em.active[k]].assign(em.cells(), kNoData);
  switch (K) {  // K known at compile time for the usual label counts: the loops unroll
    case 2:
      marginScores<2>(em, pad, num_classes, out);
      break;
    case 3:
      marginScores<3>(em, pad, num_classes, out);
      break;
    case 4:
      marginScores<4>(em, pad, num_classes, out);
      break;
    default:
      marginScores<0>(em, pad, num_classes, out);
      break;
  }
  return out;
}

// ---- RocAccumulator ----------------------------------------------------------------------------

RocAccumulator::RocAccumulator(const LabelSet& labels)
    : labels_(labels), per_class_(labels.size()) {}

void RocAccumulator::add(LabelId c, float score, bool positive, bool predicted) {
  if (c >= per_class_.size()) return;
  PerClass& pc = per_class_[c];
  ++pc.count;
  if (predicted) ++(positive ? pc.predicted_pos : pc.predicted_neg);
  pc.recent.push_back({score, positive});
  if (pc.recent.size() >= kCompactAt) compact(pc);
}

uint64_t RocAccumulator::samples(LabelId c) const {
  return c < per_class_.size() ? per_class_[c].count : 0;
}

namespace {

/// `s` with its `bits` lowest mantissa bits cleared: a monotone (non-decreasing) map, so groups
/// stay in score order when they are coarsened.
float dropBits(float s, int bits) {
  if (bits == 0) return s;
  uint32_t u;
  std::memcpy(&u, &s, 4);
  u &= ~((uint32_t(1) << bits) - 1);
  std::memcpy(&s, &u, 4);
  return s;
}

}  // namespace

std::vector<RocAccumulator::Group> RocAccumulator::allGroups(const PerClass& pc) {
  std::vector<Sample> recent = pc.recent;
  for (Sample& x : recent) x.score = dropBits(x.score, pc.bits_dropped);
  std::sort(recent.begin(), recent.end(),
            [](const Sample& a, const Sample& b) { return a.score > b.score; });
  std::vector<Group> out;
  out.reserve(pc.groups.size() + recent.size());
  auto put = [&](float score, uint64_t pos, uint64_t neg) {
    if (out.empty() || out.back().score != score) out.push_back({score, 0, 0});
    out.back().pos += pos;
    out.back().neg += neg;
  };
  std::size_t i = 0;
  for (const Group& g : pc.groups) {
    for (; i < recent.size() && recent[i].score > g.score; ++i)
      put(recent[i].score, recent[i].positive, !recent[i].positive);
    put(g.score, g.pos, g.neg);
  }
  for (; i < recent.size(); ++i) put(recent[i].score, recent[i].positive, !recent[i].positive);
  return out;
}

void RocAccumulator::compact(PerClass& pc) {
  pc.groups = allGroups(pc);
  pc.recent.clear();
  // Exact while the groups fit; beyond, coarsened to half as many, so this runs rarely.
  if (pc.groups.size() <= kMaxGroups) return;
  while (pc.groups.size() > kMaxGroups / 2 && pc.bits_dropped < 23) {
    ++pc.bits_dropped;
    std::vector<Group> coarse;
    coarse.reserve(pc.groups.size());
    for (const Group& g : pc.groups) {
      const float s = dropBits(g.score, pc.bits_dropped);
      if (coarse.empty() || coarse.back().score != s) coarse.push_back({s, 0, 0});
      coarse.back().pos += g.pos;
      coarse.back().neg += g.neg;
    }
    pc.groups.swap(coarse);
  }
}

RocFrameStats RocAccumulator::addFrame(const TerrainGrid& grid, const Frame& frame,
                                       const EnergyModel* energy) {
  const auto layers = scoreLayers(grid, labels_);
  const bool any = std::any_of(layers.begin(), layers.end(), [](const Layer* l) { return l; });
  if (any) return addFrame(grid, frame, layers, ScoreSource::kScoreLayers);
  if (energy && !energy->empty()) {
    const auto fallback = localEnergyScores(*energy, grid.labels(), labels_.size());
    if (!fallback.empty()) {
      std::vector<const Layer*> ptr(labels_.size(), nullptr);
      for (std::size_t c = 0; c < fallback.size(); ++c)
        if (!fallback[c].empty()) ptr[c] = &fallback[c];
      return addFrame(grid, frame, ptr, ScoreSource::kLocalEnergy);
    }
  }
  return addFrame(grid, frame, std::vector<const Layer*>(labels_.size(), nullptr),
                  ScoreSource::kNone);
}

RocFrameStats RocAccumulator::addFrame(const TerrainGrid& grid, const Frame& frame,
                                       const std::vector<const Layer*>& scores,
                                       ScoreSource source) {
  RocFrameStats st;
  st.source = source;
  if (frame.truth.empty()) return st;
  const std::string where = frame.source_path.empty() ? frame.id : frame.source_path;
  const std::size_t n = frame.points.size(), k = labels_.size();
  const auto& truth = frame.truth.label;
  if (truth.size() != n || grid.cellOfPoint().size() != n || grid.labels().size() != grid.cells())
    throw InputError(where, "frame " + frame.id +
                                ": ROC needs one truth label per point, a grid binned from this "
                                "frame's points and one predicted label per cell");
  for (const Layer* l : scores)
    if (l && l->size() != grid.cells())
      throw InputError(where, "frame " + frame.id + ": a score layer has " +
                                  std::to_string(l->size()) + " cells, the grid " +
                                  std::to_string(grid.cells()));
  const bool has_scores =
      std::any_of(scores.begin(), scores.end(), [](const Layer* l) { return l != nullptr; });
  const int obstacle = labels_.obstacle();
  const auto& predicted = grid.labels();
  std::vector<uint64_t> per_class(k);
  for (int cell = 0, cells = static_cast<int>(grid.cells()); cell < cells; ++cell) {
    if (grid.count(cell) == 0) continue;
    std::fill(per_class.begin(), per_class.end(), 0);
    for (const uint32_t* p = grid.pointsBegin(cell); p != grid.pointsEnd(cell); ++p)
      if (truth[*p] < k) ++per_class[truth[*p]];
    const LabelId t = cellTruth(per_class, obstacle, predicted[cell]).label;
    if (t == labels::kUnknown) continue;
    ++st.cells_scored;
    bool scored = false;
    for (std::size_t c = 1; c < k && has_scores; ++c) {
      const Layer* l = scores[c];
      if (!l) continue;
      const float s = (*l)[cell];
      if (std::isnan(s)) continue;
      scored = true;
      add(static_cast<LabelId>(c), s, t == c, predicted[cell] == c);
    }
    if (!scored) ++st.cells_without_score;
  }
  cells_scored += st.cells_scored;
  cells_without_score += st.cells_without_score;
  if (!has_scores) {
    ++frames_without_scores;
    st.source = ScoreSource::kNone;
  } else if (source == ScoreSource::kLocalEnergy) {
    ++frames_with_energy_fallback;
  } else {
    ++frames_with_layers;
  }
  return st;
}

namespace {

struct ScoreGroup {
  float score;
  uint64_t pos, neg;
};

/// Groups of equal score, highest first.
template <class Get>
std::vector<ScoreGroup> groupByScore(std::size_t n, Get get) {
  std::vector<std::pair<float, bool>> v(n);
  for (std::size_t i = 0; i < n; ++i) v[i] = get(i);
  std::sort(v.begin(), v.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<ScoreGroup> g;
  for (const auto& [s, p] : v) {
    if (g.empty() || g.back().score != s) g.push_back({s, 0, 0});
    (p ? g.back().pos : g.back().neg) += 1;
  }
  return g;
}

double aucOf(const std::vector<ScoreGroup>& groups) {
  uint64_t P = 0, N = 0;
  for (const auto& g : groups) P += g.pos, N += g.neg;
  if (P == 0 || N == 0) return kNaN;
  // Each negative earns credit for every positive scored above it and half for every tie.
  long double area = 0, tp_above = 0;
  for (const auto& g : groups) {
    area += static_cast<long double>(g.neg) * (tp_above + 0.5L * g.pos);
    tp_above += g.pos;
  }
  return static_cast<double>(area / (static_cast<long double>(P) * N));
}

}  // namespace

double rocAuc(const std::vector<float>& scores, const std::vector<bool>& positive) {
  const std::size_t n = std::min(scores.size(), positive.size());
  return aucOf(
      groupByScore(n, [&](std::size_t i) { return std::make_pair(scores[i], bool(positive[i])); }));
}

RocCurve RocAccumulator::curve(LabelId c, std::size_t max_points) const {
  RocCurve r;
  r.class_id = c;
  r.class_name = c < labels_.size() ? labels_.name(c) : std::to_string(c);
  r.auc = kNaN;
  r.operating_fpr = r.operating_tpr = kNaN;
  if (c >= per_class_.size()) return r;
  const PerClass& pc = per_class_[c];
  std::vector<ScoreGroup> groups;
  for (const Group& g : allGroups(pc)) {
    groups.push_back({g.score, g.pos, g.neg});
    r.positives += g.pos;
    r.negatives += g.neg;
  }
  r.score_bits_dropped = pc.bits_dropped;
  r.auc = aucOf(groups);
  const uint64_t op_tp = pc.predicted_pos, op_fp = pc.predicted_neg;
  if (r.positives) r.operating_tpr = double(op_tp) / r.positives;
  if (r.negatives) r.operating_fpr = double(op_fp) / r.negatives;
  // Without positives (or negatives) the rate is undefined: NaN, an empty CSV field, not 0.
  auto rate = [](uint64_t a, uint64_t b) { return b ? double(a) / b : kNaN; };
  std::vector<RocPoint> pts;
  pts.reserve(groups.size() + 1);
  pts.push_back({std::numeric_limits<double>::infinity(), 0, 0, 0, 0});
  uint64_t tp = 0, fp = 0;
  for (const auto& g : groups) {
    tp += g.pos;
    fp += g.neg;
    pts.push_back({g.score, tp, fp, rate(tp, r.positives), rate(fp, r.negatives)});
  }
  if (max_points >= 2 && pts.size() > max_points) {
    // Keep the ends and evenly spaced points in between: the curve is monotone, so the thinned
    // polyline stays within one step of the full one.
    std::vector<RocPoint> thin;
    thin.reserve(max_points);
    const double step = double(pts.size() - 1) / double(max_points - 1);
    std::size_t last = SIZE_MAX;
    for (std::size_t i = 0; i < max_points; ++i) {
      const std::size_t j =
          std::min(pts.size() - 1, static_cast<std::size_t>(std::llround(i * step)));
      if (j != last) thin.push_back(pts[j]);
      last = j;
    }
    pts.swap(thin);
  }
  r.points = std::move(pts);
  return r;
}

std::vector<RocCurve> RocAccumulator::curves(std::size_t max_points) const {
  std::vector<RocCurve> out;
  for (std::size_t c = 1; c < per_class_.size(); ++c)
    if (per_class_[c].count > 0) out.push_back(curve(static_cast<LabelId>(c), max_points));
  return out;
}

// ---- writers ---------------------------------------------------------------------------------

std::string rocCsv(const std::vector<RocCurve>& curves, const std::string& run) {
  std::ostringstream o;
  if (!run.empty()) o << "run,";
  o << "class,threshold,fpr,tpr,tp,fp,positives,negatives\n";
  for (const auto& c : curves) {
    for (const auto& p : c.points) {
      if (!run.empty()) o << run << ",";
      // Scores are floats: 9 digits tell every distinct threshold apart (6 merged e.g.
      // 0.99999994 with 1).
      o << c.class_name << "," << num(p.threshold, "%.9g") << "," << num(p.fpr) << "," << num(p.tpr) << ","
        << p.tp << "," << p.fp << "," << c.positives << "," << c.negatives << "\n";
    }
  }
  return o.str();
}

std::string rocSummaryJson(const std::vector<RocCurve>& curves) {
  std::ostringstream o;
  o << "[";
  for (std::size_t i = 0; i < curves.size(); ++i) {
    const auto& c = curves[i];
    o << (i ? ", " : "") << "{\"class\": " << jsonQuote(c.class_name)
      << ", \"positives\": " << c.positives << ", \"negatives\": " << c.negatives
      << ", \"auc\": " << jsonNum(c.auc) << ", \"operating_fpr\": " << jsonNum(c.operating_fpr)
      << ", \"operating_tpr\": " << jsonNum(c.operating_tpr);
    // Only where it happened (a very long run): exact curves keep their record unchanged.
    if (c.score_bits_dropped > 0) o << ", \"score_bits_dropped\": " << c.score_bits_dropped;
    o << "}";
  }
  o << "]";
  return o.str();
}

std::string rocSvg(const std::vector<RocCurve>& curves, const LabelSet& labels,
                   const std::string& title) {
  // Plot area 400×400 px with margins for the axis labels and a legend on the right.
  const double L = 60, T = 40, S = 400, W = L + S + 200, H = T + S + 50;
  auto X = [&](double fpr) { return L + fpr * S; };
  auto Y = [&](double tpr) { return T + (1.0 - tpr) * S; };
  auto colour = [&](LabelId id) {
    std::array<uint8_t, 3> rgb = {0, 0, 0};
    if (id < labels.size()) rgb = labels[id].rgb;
    // Very light class colours (e.g. a pale grey road) would vanish on white: darken them.
    const int lum = (299 * rgb[0] + 587 * rgb[1] + 114 * rgb[2]) / 1000;
    if (lum > 170)
      for (auto& v : rgb) v = static_cast<uint8_t>(v * 0.6);
    char b[16];
    std::snprintf(b, sizeof b, "#%02x%02x%02x", rgb[0], rgb[1], rgb[2]);
    return std::string(b);
  };
  std::ostringstream o;
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << W << "\" height=\"" << H
    << "\" viewBox=\"0 0 " << W << " " << H << "\" font-family=\"sans-serif\" font-size=\"12\">\n";
  o << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  o << "<text x=\"" << L + S / 2 << "\" y=\"22\" text-anchor=\"middle\" font-size=\"14\">"
    << xmlEscape(title) << "</text>\n";
  // Grid and ticks.
  for (int i = 0; i <= 10; ++i) {
    const double v = i / 10.0;
    o << "<line x1=\"" << X(v) << "\" y1=\"" << Y(0) << "\" x2=\"" << X(v) << "\" y2=\"" << Y(1)
      << "\" stroke=\"#e0e0e0\"/>\n";
    o << "<line x1=\"" << X(0) << "\" y1=\"" << Y(v) << "\" x2=\"" << X(1) << "\" y2=\"" << Y(v)
      << "\" stroke=\"#e0e0e0\"/>\n";
    if (i % 2 == 0) {
      o << "<text x=\"" << X(v) << "\" y=\"" << Y(0) + 16 << "\" text-anchor=\"middle\">"
        << num(v, "%.1f") << "</text>\n";
      o << "<text x=\"" << X(0) - 6 << "\" y=\"" << Y(v) + 4 << "\" text-anchor=\"end\">"
        << num(v, "%.1f") << "</text>\n";
    }
  }
  o << "<rect x=\"" << L << "\" y=\"" << T << "\" width=\"" << S << "\" height=\"" << S
    << "\" fill=\"none\" stroke=\"black\"/>\n";
  o << "<line x1=\"" << X(0) << "\" y1=\"" << Y(0) << "\" x2=\"" << X(1) << "\" y2=\"" << Y(1)
    << "\" stroke=\"#999\" stroke-dasharray=\"4 4\"/>\n";
  o << "<text x=\"" << L + S / 2 << "\" y=\"" << H - 12
    << "\" text-anchor=\"middle\">false positive rate</text>\n";
  o << "<text x=\"16\" y=\"" << T + S / 2 << "\" text-anchor=\"middle\" transform=\"rotate(-90 16 "
    << T + S / 2 << ")\">true positive rate</text>\n";
  // Curves, operating points, legend.
  double ly = T + 10;
  for (const auto& c : curves) {
    const std::string col = colour(c.class_id);
    if (c.defined() && !c.points.empty()) {
      o << "<polyline fill=\"none\" stroke=\"" << col << "\" stroke-width=\"2\" points=\"";
      for (const auto& p : c.points)
        o << num(X(p.fpr), "%.2f") << "," << num(Y(p.tpr), "%.2f") << " ";
      o << "\"/>\n";
      if (std::isfinite(c.operating_fpr) && std::isfinite(c.operating_tpr))
        o << "<circle cx=\"" << X(c.operating_fpr) << "\" cy=\"" << Y(c.operating_tpr)
          << "\" r=\"4\" fill=\"" << col << "\" stroke=\"black\"/>\n";
    }
    o << "<line x1=\"" << L + S + 15 << "\" y1=\"" << ly << "\" x2=\"" << L + S + 40 << "\" y2=\""
      << ly << "\" stroke=\"" << col << "\" stroke-width=\"2\"/>\n";
    std::string text =
        c.class_name +
        (c.defined() ? "  AUC " + num(c.auc, "%.3f")
                     : "  (no " + std::string(c.positives ? "negatives" : "positives") + ")");
    o << "<text x=\"" << L + S + 46 << "\" y=\"" << ly + 4 << "\">" << xmlEscape(text)
      << "</text>\n";
    ly += 18;
  }
  if (curves.empty())
    o << "<text x=\"" << L + S / 2 << "\" y=\"" << T + S / 2
      << "\" text-anchor=\"middle\">no scored cells</text>\n";
  o << "<text x=\"" << L + S + 15 << "\" y=\"" << ly + 8
    << "\" font-size=\"10\">dot: the labelling's own (FPR, TPR)</text>\n";
  o << "</svg>\n";
  return o.str();
}

}  // namespace terramrf
