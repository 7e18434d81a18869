#pragma once
// α-expansion's moves as minimum cuts (Boykov, Veksler & Zabih 2001) with Kolmogorov's
// Boykov–Kolmogorov max-flow (Debian's libmaxflow). Every expansion is one min-cut; each label
// keeps the residual network of its last cut (cells, 8-neighbour pairs) for the frame, and its
// next cut starts from it (Kohli & Torr 2007): only the capacities that changed are written. The
// max-flow then runs on a region around the nodes still sending to the sink, grown until it
// provably holds the whole cut (cutResidual), so a cut after a few cells changed label costs
// little more than those cells.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "frame_graph.hpp"
#include "terramrf/energy_model.hpp"

namespace maxflow {
template <typename captype, typename tcaptype, typename flowtype>
class Graph;
}

namespace terramrf::expansion {

class ExpansionCuts {
 public:
  ExpansionCuts();
  ~ExpansionCuts();  // the max-flow graph is a complete type only in the .cpp

  /// Starts a frame: builds the graph of the non-fixed cells, chooses the capacity scale from the
  /// range of the (clipped) unary differences and the Potts weights, and sets every label's network
  /// to be built by its first cut.
  void beginFrame(const EnergyModel& em);

  /// Logs that cell `cell` changed label; every label's next cut reads the log.
  void labelChanged(int cell) { changes_.push_back(fg_.node_of[cell]); }

  /// Best α-expansion of `lab` by one min-cut: the cells that would take α go to move(). Returns
  /// false if there are none.
  ///
  /// Each label keeps the residual network of its last cut for the frame (Kohli & Torr 2007): it
  /// represents that move energy up to a constant, so the new move energy is that residual plus
  /// the change of the capacities, which only the cells whose label changed since (their pairs,
  /// and their and their neighbours' t-links) have. Those are written, and the max-flow runs
  /// only around the nodes left sending to the sink (cutResidual): an expansion after a few
  /// changed cells costs about as much as those cells.
  bool expand(const EnergyModel& em, const std::vector<uint8_t>& lab, int alpha);
  /// The cells of the last expansion's move (those that would take α), in node order.
  const std::vector<int>& move() const { return move_; }

  /// Max-flows run since beginFrame (a cut whose region grew runs several).
  long maxFlows() const { return region_cuts_; }
  /// Nodes in those max-flows' networks, summed.
  long maxFlowNodes() const { return region_nodes_; }
  /// Times a cut's region had to grow.
  long regrowths() const { return region_regrowths_; }

 private:
  /// 64-bit capacities: 2^36 units for the largest capacity leave room for 2^26 nodes.
  using CutGraph = maxflow::Graph<int64_t, int64_t, int64_t>;

  /// One label's move energy for the frame: the residual network of a maximum flow after its
  /// last cut, and the move energy that cut was for (to write only what changed since).
  struct WarmStart {
    bool cold = true;              ///< no cut yet in this frame
    std::vector<int64_t> res_t;    ///< per node: residual t-link (> 0 source, < 0 sink)
    std::vector<int64_t> res_n;    ///< per pair: residual n-links, p→q then q→p
    std::vector<int64_t> model_t;  ///< per node: cost(x=1) − cost(x=0)
    std::vector<int64_t> model_n;  ///< per pair: c01 (p→q), c10 (q→p)
    std::vector<uint8_t> lab_at;   ///< per node: its label at that cut
    std::size_t changes_at = 0;    ///< changes_ up to here are in that cut's capacities
  };

  /// Potts pair term of an expansion, with A = V(a,b), B = V(a,α), C = V(α,b), D = V(α,α) = 0
  /// (Kolmogorov & Zabih 2004), written as A + s·x_p + t·x_q + c01·(1−x_p)·x_q + c10·x_p·(1−x_q)
  /// with s + t = D − A, c10 = C − A − s ≥ 0, c01 = B − A − t ≥ 0 (possible as V is a metric:
  /// B + C ≥ A + D), and s as near −A/2 as allowed, which splits the term symmetrically: two
  /// equal labels give two n-links of V and no t-link, instead of opposing t-links whose flow the
  /// max-flow would have to push through every such pair. For Potts only five cases exist:
  ///   a = b ≠ α:      s = t = 0,            c01 = c10 = V
  ///   a ≠ b, both ≠ α: s = −⌊V/2⌋, t = −⌈V/2⌉, c01 = ⌈V/2⌉, c10 = ⌊V/2⌋
  ///   a = α ≠ b:      s = 0, t = −V          (p is α either way: q pays V unless it joins)
  ///   b = α ≠ a:      s = −V, t = 0
  ///   a = b = α:      nothing.
  struct PairTerm {
    int64_t s = 0, t = 0, c01 = 0, c10 = 0;
  };
  static PairTerm pairTerm(int a, int b, int alpha, int64_t V);

  /// Energy → integer capacity units, rounded to nearest.
  int64_t toUnits(double x) const;

  /// Writes pair k's new n-link capacities into α's residual network (the previous residual plus
  /// the change of the model); a deficit goes to the t-links via shift_t_.
  void updatePair(WarmStart& w, std::size_t k, const PairTerm& m);

  /// Writes node n's new t-link (signed: > 0 from the source, cut when the cell takes α; < 0 to
  /// the sink) into α's residual network.
  void updateNode(WarmStart& w, int n, int64_t model);

  /// Node n's unary difference cost(α) − cost(its label), clipped to ±unary_clip_[n] (which
  /// changes no cut, beginFrame), in capacity units.
  int64_t unaryModel(const EnergyModel& em, const std::vector<uint8_t>& lab, int alpha, int n);

  /// Node n's model t-link: its unary difference plus its share of its pairs' terms.
  int64_t nodeModel(const EnergyModel& em, const std::vector<uint8_t>& lab, int alpha, int n);

  /// Completes the flow in α's residual network to a maximum flow and puts the cells on the sink
  /// side of the minimum cut into move_: those that can still send to the sink, the least set of
  /// cells a best move needs (of equally good moves, the smallest).
  ///
  /// Only the neighbourhood of the nodes still sending to the sink needs the max-flow. Every
  /// other node has source capacity left, so it is on the source side, and whatever reaches the
  /// sink enters that neighbourhood from outside over an arc with residual capacity. So the
  /// region is the nodes within `depth` such arcs backwards of those sending to the sink; its
  /// last layer, the ring, holds its own t-links but not its arcs further out. After a max-flow on
  /// that subnetwork, if no ring node can reach the sink, no path from the source can either: it
  /// would have to enter through a ring node, which has source capacity or a path to the source
  /// within the region. Then the region's sink side is the whole graph's. Otherwise the region
  /// grows outwards from the ring nodes that can reach the sink, twice as deep each time: the
  /// new nodes and their pairs are added to the library's network, which keeps the flow found so
  /// far, and its max-flow runs again with fresh search trees. (Reusing its trees, with the new
  /// nodes and arc ends marked, took 6 % more instructions on the stress grid; rebuilding the
  /// network from scratch, 4 % more.)
  bool cutResidual(WarmStart& w, const std::vector<uint8_t>& lab, int alpha);

  /// Before a cold cut, on its residual network (res_t per node, res_n per pair): most of the flow
  /// runs s → q → p → t between neighbours, and much of the rest through a few cells between them.
  /// Pushing it greedily, in a pass over the pairs, then along shortest paths found by short
  /// searches back from each cell still sending to the sink, leaves the max-flow much less to
  /// augment and far fewer nodes to start its region from (cutResidual). The cut is the same: the
  /// nodes that can reach t in the residual network are the same for every maximum flow.
  void greedyFlow(int64_t* const res_t, int64_t* const res_n);

  FrameGraph fg_;
  double scale_ = 1;  ///< capacity units per energy unit
  /// Per node: the bound its unary differences are clipped to, in energy units (beginFrame).
  std::vector<double> unary_clip_;
  std::vector<WarmStart> warm_;
  std::vector<int64_t> shift_t_;  ///< per node: deficits moved off n-links, not yet written
  /// Depth of a cut's region, in arcs back from the nodes sending to the sink (cutResidual).
  static constexpr int kRegionDepth = 2;
  std::unique_ptr<CutGraph> region_graph_;  ///< the region's max-flow network, reset per cut
  std::vector<int> region_;              ///< a cut's region: nodes in the order added, seeds first
  std::vector<int> layer_, next_layer_;  ///< a cut's region: the layer a growth starts from
  std::vector<int> ring_;                ///< a cut's region: nodes with arcs in from outside
  std::vector<int> local_of_;            ///< per node: its place in region_, −1 outside
  std::vector<int> region_pairs_;        ///< pairs with arcs in the region network, in arc order
  long region_cuts_ = 0, region_nodes_ = 0, region_regrowths_ = 0;
  std::vector<int> touched_;        ///< nodes whose t-link is rewritten in this cut
  std::vector<uint32_t> bfs_from_;  ///< per node: the arc the search reached it by
  std::vector<uint32_t> bfs_seen_;  ///< per node: the stamp of the search that reached it
  std::vector<uint8_t> dry_;        ///< per node: a search through it came up short
  uint32_t bfs_stamp_ = 0;
  std::vector<int> changes_;  ///< nodes, each time its cell's label changed in this frame
  std::vector<uint8_t> node_seen_, pair_seen_;
  std::vector<int> move_;
};

}  // namespace terramrf::expansion
