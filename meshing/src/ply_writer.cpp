// PLY export through CGAL::Surface_mesh: the tiles go into one mesh with vertex property maps
// (colour, class) that CGAL's PLY writer emits as `red green blue alpha` and `class`.
// The only CGAL translation unit of the library (CGAL headers compile slowly).
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>

#include <stdexcept>

#include "terramrf/atomic_file.hpp"
#include "terramrf/meshing/mesh_export.hpp"

namespace terramrf::meshing {

namespace {
using Kernel = CGAL::Simple_cartesian<double>;
using SurfaceMesh = CGAL::Surface_mesh<Kernel::Point_3>;
using VI = SurfaceMesh::Vertex_index;
}  // namespace

void writePly(const std::vector<TileMesh>& tiles, const std::string& path) {
  SurfaceMesh sm;
  auto colour =
      sm.add_property_map<VI, CGAL::IO::Color>("v:color", CGAL::IO::Color(128, 128, 128)).first;
  auto cls = sm.add_property_map<VI, uint8_t>("v:class", 0).first;
  std::size_t relinked = 0;
  for (const TileMesh& m : tiles) {
    std::vector<VI> vi(m.positions.size());
    for (std::size_t k = 0; k < m.positions.size(); ++k) {
      const auto& p = m.positions[k];
      vi[k] = sm.add_vertex(Kernel::Point_3(p[0], p[1], p[2]));
      colour[vi[k]] = CGAL::IO::Color(m.colours[k][0], m.colours[k][1], m.colours[k][2]);
      cls[vi[k]] = m.classes[k];
    }
    for (const auto& t : m.triangles) {
      if (sm.add_face(vi[t[0]], vi[t[1]], vi[t[2]]) != SurfaceMesh::null_face()) continue;
      // A vertex where two fans of triangles meet only at that vertex cannot always be linked:
      // give this triangle its own copies of the corners (same positions, colours, classes).
      VI c[3];
      for (int e = 0; e < 3; ++e) {
        c[e] = sm.add_vertex(sm.point(vi[t[e]]));
        colour[c[e]] = colour[vi[t[e]]];
        cls[c[e]] = cls[vi[t[e]]];
      }
      sm.add_face(c[0], c[1], c[2]);
      ++relinked;
    }
  }
  // Streamed to the file: an encoded copy in memory would be another mesh's worth.
  AtomicFileWriter file(path);
  std::ostream& os = file.stream();
  CGAL::IO::set_binary_mode(os);
  const std::string comments =
      "TerraMRF textured terrain mesh (paper 004); world frame [m]; class: 0 unknown, 1 ground, "
      "2 object, 3 tree, 4 building" +
      (relinked ? "; " + std::to_string(relinked) + " triangles with duplicated corners"
                : std::string());
  if (!CGAL::IO::write_PLY(os, sm, comments)) {
    file.checkWritten();  // a full disk names the file; else it was the encoding
    throw std::runtime_error("CGAL could not encode the PLY");
  }
  file.commit();
}

}  // namespace terramrf::meshing
