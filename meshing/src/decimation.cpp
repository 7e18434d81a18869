// Flat-region decimation of a tile through CGAL::Surface_mesh_simplification::edge_collapse with
// our own placement (keep an endpoint), cost (vertical deviation of the original vertices from the
// new triangles, in the x-y projection) and bookkeeping of which original vertices lie in which
// face. A CGAL translation unit: no LCM header may be included here.
#include "terramrf/meshing/decimation.hpp"

#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_simplification/Edge_collapse_visitor_base.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <vector>

namespace terramrf::meshing {

namespace {

namespace SMS = CGAL::Surface_mesh_simplification;
using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;
using VI = SurfaceMesh::Vertex_index;
using FI = SurfaceMesh::Face_index;
using HI = SurfaceMesh::Halfedge_index;
using Profile = SMS::Edge_profile<SurfaceMesh>;

// Shared state of placement, cost and visitor (CGAL copies the policies; they hold a pointer).
struct State {
  SurfaceMesh sm;
  const TileMesh* tile = nullptr;
  double tol = 0;
  SurfaceMesh::Property_map<VI, uint32_t> orig;  // index into the tile's vertex arrays
  SurfaceMesh::Property_map<VI, uint8_t> fixed;  // on the tile's edge or a class boundary
  SurfaceMesh::Property_map<FI, std::vector<uint32_t>> inside;  // removed originals in the face
  // Scratch of one evaluation.
  std::vector<std::array<VI, 3>> tris;
  std::vector<uint32_t> gathered;
  // Collapse in progress.
  uint32_t kept_orig = 0;
  uint8_t kept_fixed = 0;
  VI removed;
  std::vector<uint32_t> moving;
  double max_dev = 0;

  // Samples of the original surface that must stay within the tolerance: the original vertices
  // (ids 0..n−1, same as their vertex index) and the centroids of the original triangles (a
  // surface between vertices, e.g. a bump's flank, is then checked too).
  std::vector<std::array<double, 3>> samples;
  const std::array<double, 3>& pos(uint32_t q) const { return samples[q]; }

  // Vertical deviation of the originals around `r` when `r` is removed and its triangles are
  // re-fanned from `k`; nullopt when not allowed (fixed vertex, fold, beyond the tolerance).
  // Without `exact`, only the removed vertex itself is checked: the cheap estimate CGAL keeps in
  // its queue for every edge (recomputed around each collapse); the exact test over all samples
  // runs once, when the edge is taken from the queue (Visitor::OnSelected).
  std::optional<double> evaluate(VI r, VI k, bool exact) {
    if (fixed[r]) return std::nullopt;
    // On the border of a hole (sparse LiDAR rings leave many), `r` may only slide along the
    // border onto a border neighbour, and only where the border runs straight through it: the
    // outline of the mesh stays exactly where it was.
    HI in_border = SurfaceMesh::null_halfedge();
    for (HI h : CGAL::halfedges_around_target(sm.halfedge(r), sm)) {
      if (sm.face(h) != SurfaceMesh::null_face()) continue;
      if (in_border != SurfaceMesh::null_halfedge()) return std::nullopt;  // two holes touch here
      in_border = h;
    }
    if (in_border != SurfaceMesh::null_halfedge()) {
      const VI a = sm.source(in_border), b = sm.target(sm.next(in_border));
      if (k != a && k != b) return std::nullopt;
      const Point &pa = sm.point(a), &pb = sm.point(b), &pr = sm.point(r);
      const double cross =
          (pr.x() - pa.x()) * (pb.y() - pa.y()) - (pr.y() - pa.y()) * (pb.x() - pa.x());
      const double dot =
          (pr.x() - pa.x()) * (pb.x() - pr.x()) + (pr.y() - pa.y()) * (pb.y() - pr.y());
      if (std::abs(cross) > 1e-9 || dot <= 0) return std::nullopt;
    }
    tris.clear();
    gathered.clear();
    gathered.push_back(orig[r]);
    for (HI h : CGAL::halfedges_around_target(sm.halfedge(r), sm)) {
      const FI f = sm.face(h);
      if (f == SurfaceMesh::null_face()) continue;
      if (exact) {
        const auto& in = inside[f];
        gathered.insert(gathered.end(), in.begin(), in.end());
      }
      const VI a = sm.target(sm.next(h)), b = sm.source(h);
      if (a == k || b == k) continue;  // the two triangles on the collapsed edge disappear
      const Point &pk = sm.point(k), &pa = sm.point(a), &pb = sm.point(b);
      const double area2 =
          (pa.x() - pk.x()) * (pb.y() - pk.y()) - (pa.y() - pk.y()) * (pb.x() - pk.x());
      if (area2 <= 1e-9) return std::nullopt;  // the fan would fold over (x-y projection)
      tris.push_back({k, a, b});
    }
    double dev = 0;
    for (uint32_t q : gathered) {
      const auto& Q = pos(q);
      bool found = false;
      for (const auto& t : tris) {
        const Point &A = sm.point(t[0]), &B = sm.point(t[1]), &C = sm.point(t[2]);
        const double d = (B.y() - C.y()) * (A.x() - C.x()) + (C.x() - B.x()) * (A.y() - C.y());
        const double l1 = ((B.y() - C.y()) * (Q[0] - C.x()) + (C.x() - B.x()) * (Q[1] - C.y())) / d;
        const double l2 = ((C.y() - A.y()) * (Q[0] - C.x()) + (A.x() - C.x()) * (Q[1] - C.y())) / d;
        const double l3 = 1 - l1 - l2;
        constexpr double kEps = -1e-9;
        if (l1 < kEps || l2 < kEps || l3 < kEps) continue;
        dev = std::max(dev, std::abs(l1 * A.z() + l2 * B.z() + l3 * C.z() - Q[2]));
        found = true;
        break;
      }
      if (!found || dev > tol) return std::nullopt;
    }
    return dev;
  }

  bool exact = false;  // set when CGAL selects an edge for collapse
  // Last placement decision, reused by Cost (CGAL asks for the placement, then its cost).
  VI last_v0, last_v1;
  bool last_keep1 = false;
  double last_dev = 0;

  // The better of the two directions: (keep v1?, deviation).
  std::optional<std::pair<bool, double>> best(const Profile& pr) {
    const bool ex = exact;
    exact = false;
    const auto a = evaluate(pr.v0(), pr.v1(), ex);  // keep v1
    const auto b = evaluate(pr.v1(), pr.v0(), ex);  // keep v0
    if (!a && !b) return std::nullopt;
    const auto r = a && (!b || *a <= *b) ? std::make_pair(true, *a) : std::make_pair(false, *b);
    last_v0 = pr.v0();
    last_v1 = pr.v1();
    last_keep1 = r.first;
    last_dev = r.second;
    return r;
  }
};

struct Placement {
  State* s;
  boost::optional<Point> operator()(const Profile& pr) const {
    const auto b = s->best(pr);
    if (!b) return boost::none;
    return b->first ? pr.p1() : pr.p0();
  }
};

struct Cost {
  State* s;
  boost::optional<double> operator()(const Profile& pr,
                                     const boost::optional<Point>& placement) const {
    if (!placement) return boost::none;
    const bool keep1 = *placement == pr.p1();
    if (pr.v0() == s->last_v0 && pr.v1() == s->last_v1 && keep1 == s->last_keep1)
      return s->last_dev;
    const auto d =
        keep1 ? s->evaluate(pr.v0(), pr.v1(), false) : s->evaluate(pr.v1(), pr.v0(), false);
    if (!d) return boost::none;
    return *d;
  }
};

// Collapses only happen where the cost (deviation) is defined, i.e. within the tolerance; the
// queue is simply run dry.
struct NeverStop {
  bool operator()(const double&, const Profile&, std::size_t, std::size_t) const { return false; }
};

struct Visitor : SMS::Edge_collapse_visitor_base<SurfaceMesh> {
  State* s;
  explicit Visitor(State* st) : s(st) {}
  void OnSelected(const Profile&, const boost::optional<double>&, std::size_t, std::size_t) {
    s->exact = true;  // the placement CGAL asks for next decides the collapse
  }
  void OnCollapsing(const Profile& pr, const boost::optional<Point>& placement) {
    const bool keep1 = *placement == pr.p1();
    const VI r = keep1 ? pr.v0() : pr.v1(), k = keep1 ? pr.v1() : pr.v0();
    s->kept_orig = s->orig[k];
    s->kept_fixed = s->fixed[k];
    s->removed = r;
    s->moving.clear();
    s->moving.push_back(s->orig[r]);
    for (HI h : CGAL::halfedges_around_target(s->sm.halfedge(r), s->sm)) {
      const FI f = s->sm.face(h);
      if (f == SurfaceMesh::null_face()) continue;
      auto& in = s->inside[f];
      s->moving.insert(s->moving.end(), in.begin(), in.end());
      in.clear();
    }
  }
  void OnCollapsed(const Profile&, VI v) {
    s->orig[v] = s->kept_orig;
    s->fixed[v] = s->kept_fixed;  // CGAL may keep either handle; the attributes are the kept one's
    // Hand every moved original to the new triangle it lies in (x-y projection).
    for (uint32_t q : s->moving) {
      const auto& Q = s->pos(q);
      FI best = SurfaceMesh::null_face();
      double best_min = -1e30, best_z = 0;
      for (HI h : CGAL::halfedges_around_target(s->sm.halfedge(v), s->sm)) {
        const FI f = s->sm.face(h);
        if (f == SurfaceMesh::null_face()) continue;
        const HI h0 = s->sm.halfedge(f);
        const Point& A = s->sm.point(s->sm.source(h0));
        const Point& B = s->sm.point(s->sm.target(h0));
        const Point& C = s->sm.point(s->sm.target(s->sm.next(h0)));
        const double d = (B.y() - C.y()) * (A.x() - C.x()) + (C.x() - B.x()) * (A.y() - C.y());
        const double l1 = ((B.y() - C.y()) * (Q[0] - C.x()) + (C.x() - B.x()) * (Q[1] - C.y())) / d;
        const double l2 = ((C.y() - A.y()) * (Q[0] - C.x()) + (A.x() - C.x()) * (Q[1] - C.y())) / d;
        const double l3 = 1 - l1 - l2;
        const double m = std::min({l1, l2, l3});
        if (m > best_min) {  // the containing face, or the nearest one for rounding cases
          best_min = m;
          best = f;
          best_z = l1 * A.z() + l2 * B.z() + l3 * C.z();
        }
      }
      if (best == SurfaceMesh::null_face()) continue;
      s->inside[best].push_back(q);
      s->max_dev = std::max(s->max_dev, std::abs(best_z - Q[2]));
    }
  }
};

}  // namespace

DecimationStats decimateTileMesh(TileMesh& m, double tol) {
  if (!(tol >= 0)) throw std::invalid_argument("flat_tolerance_m must be >= 0");
  DecimationStats st;
  st.triangles_before = st.triangles_after = m.triangles.size();
  st.vertices_before = st.vertices_after = m.positions.size();
  if (m.triangles.empty() || tol <= 0) return st;
  State s;
  s.tile = &m;
  s.tol = tol;
  SurfaceMesh& sm = s.sm;
  s.orig = sm.add_property_map<VI, uint32_t>("v:orig", 0).first;
  s.fixed = sm.add_property_map<VI, uint8_t>("v:fixed", 0).first;
  s.inside = sm.add_property_map<FI, std::vector<uint32_t>>("f:inside").first;
  s.samples = m.positions;
  std::vector<VI> vi(m.positions.size());
  for (std::size_t k = 0; k < m.positions.size(); ++k) {
    const auto& p = m.positions[k];
    vi[k] = sm.add_vertex(Point(p[0], p[1], p[2]));
    s.orig[vi[k]] = uint32_t(k);
  }
  for (const auto& t : m.triangles) {
    std::array<double, 3> ctr{0, 0, 0};
    for (int e = 0; e < 3; ++e)
      for (int a = 0; a < 3; ++a) ctr[a] += m.positions[t[e]][a] / 3;
    const uint32_t centroid = uint32_t(s.samples.size());
    s.samples.push_back(ctr);
    const FI f = sm.add_face(vi[t[0]], vi[t[1]], vi[t[2]]);
    if (f != SurfaceMesh::null_face()) {
      s.inside[f].push_back(centroid);
      continue;
    }
    // Non-manifold corner (two fans meeting at a vertex): the triangle gets its own copies of
    // its corners; they lie on borders, hence stay.
    VI c[3];
    for (int e = 0; e < 3; ++e) {
      c[e] = sm.add_vertex(sm.point(vi[t[e]]));
      s.orig[c[e]] = t[e];
    }
    const FI g = sm.add_face(c[0], c[1], c[2]);
    if (g != SurfaceMesh::null_face()) s.inside[g].push_back(centroid);
  }
  // Fixed: the tile's edge (shared with the neighbouring tiles, which decimate on their own; every
  // vertex on the lines of the data's bounding box, a superset of it), triangles that needed
  // their own corners, and class boundaries.
  double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
  for (const auto& p : m.positions) {
    xmin = std::min(xmin, p[0]);
    xmax = std::max(xmax, p[0]);
    ymin = std::min(ymin, p[1]);
    ymax = std::max(ymax, p[1]);
  }
  for (VI v : sm.vertices()) {
    const Point& p = sm.point(v);
    if (p.x() == xmin || p.x() == xmax || p.y() == ymin || p.y() == ymax ||
        std::size_t(v) >= vi.size())
      s.fixed[v] = 1;
  }
  for (auto e : sm.edges()) {
    const HI h = sm.halfedge(e);
    const VI a = sm.source(h), b = sm.target(h);
    if (m.classes[s.orig[a]] != m.classes[s.orig[b]]) {
      s.fixed[a] = 1;
      s.fixed[b] = 1;
    }
  }
  // Isolated vertices (none expected) are fixed too.
  for (VI v : sm.vertices())
    if (sm.halfedge(v) == SurfaceMesh::null_halfedge()) s.fixed[v] = 1;
  Visitor vis(&s);
  SMS::edge_collapse(
      sm, NeverStop(),
      CGAL::parameters::get_cost(Cost{&s}).get_placement(Placement{&s}).visitor(vis));
  // Back to an indexed mesh of the kept original vertices.
  TileMesh out;
  out.name = m.name;
  out.texture = m.texture;
  std::vector<int32_t> index(m.positions.size(), -1);
  out.positions.reserve(sm.number_of_vertices());  // exact: every kept vertex is in a face
  out.uvs.reserve(sm.number_of_vertices());
  out.colours.reserve(sm.number_of_vertices());
  out.classes.reserve(sm.number_of_vertices());
  out.triangles.reserve(sm.number_of_faces());
  auto id = [&](VI v) -> uint32_t {
    const uint32_t q = s.orig[v];
    if (index[q] < 0) {
      index[q] = int32_t(out.positions.size());
      out.positions.push_back(m.positions[q]);
      out.uvs.push_back(m.uvs[q]);
      out.colours.push_back(m.colours[q]);
      out.classes.push_back(m.classes[q]);
    }
    return uint32_t(index[q]);
  };
  for (FI f : sm.faces()) {
    const HI h = sm.halfedge(f);
    out.triangles.push_back({id(sm.source(h)), id(sm.target(h)), id(sm.target(sm.next(h)))});
  }
  st.triangles_after = out.triangles.size();
  st.vertices_after = out.positions.size();
  st.max_deviation_m = s.max_dev;
  m = std::move(out);
  return st;
}

}  // namespace terramrf::meshing
