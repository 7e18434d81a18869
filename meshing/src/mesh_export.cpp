// Tile triangulation, OBJ/MTL/PNG writer and the all-or-nothing export folder swap.
#include "terramrf/meshing/mesh_export.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <stdexcept>

#include "terramrf/adapters/opencv_image.hpp"
#include "terramrf/atomic_file.hpp"
#include "terramrf/meshing/decimation.hpp"

namespace terramrf::meshing {

namespace fs = std::filesystem;

namespace {
std::string tileName(int ti, int tj) {
  auto idx = [](int v) { return v < 0 ? "m" + std::to_string(-v) : std::to_string(v); };
  return "tile_" + idx(ti) + "_" + idx(tj);
}
}  // namespace

std::vector<TileMesh> extractTileMeshes(const TerrainMesh& mesh) {
  std::vector<TileMesh> out;
  const int tpc = mesh.params().texels_per_cell, T = mesh.textureSize();
  for (const auto& [key, tp] : mesh.tiles()) {
    const Tile& t = *tp;
    const int n = t.n;
    std::vector<float> h(t.vertices());
    for (std::size_t k = 0; k < h.size(); ++k) h[k] = mesh.displayHeight(t, int(k));
    std::vector<int32_t> index(t.vertices(), -1);
    TileMesh m;
    m.name = tileName(t.ti, t.tj);
    m.texture = &t.texture;
    auto vid = [&](int i, int j) -> uint32_t {
      const int k = i * n + j;
      if (index[k] < 0) {
        index[k] = int32_t(m.positions.size());
        const Eigen::Vector3d p = mesh.vertexPosition(t, i, j);
        m.positions.push_back({p.x(), p.y(), p.z()});
        const Eigen::Vector2f uv = mesh.vertexUv(i, j);
        m.uvs.push_back({uv.x(), uv.y()});
        const uint8_t* c = t.texture.at(j * tpc, i * tpc);
        m.colours.push_back({c[0], c[1], c[2]});
        m.classes.push_back(uint8_t(t.cls[k]));
      }
      return uint32_t(index[k]);
    };
    auto ok = [&](int i, int j) { return !std::isnan(h[i * n + j]); };
    for (int i = 0; i + 1 < n; ++i) {
      for (int j = 0; j + 1 < n; ++j) {
        // Corners: a=(i,j) b=(i+1,j) c=(i+1,j+1) d=(i,j+1); x = i (forward), y = j (left), so
        // a→b→c is counter-clockwise seen from above (+z).
        const bool a = ok(i, j), b = ok(i + 1, j), c = ok(i + 1, j + 1), d = ok(i, j + 1);
        const int cnt = a + b + c + d;
        if (cnt < 3) continue;
        if (cnt == 4) {
          const float dac = std::abs(h[i * n + j] - h[(i + 1) * n + j + 1]);
          const float dbd = std::abs(h[(i + 1) * n + j] - h[i * n + j + 1]);
          if (dac <= dbd) {
            m.triangles.push_back({vid(i, j), vid(i + 1, j), vid(i + 1, j + 1)});
            m.triangles.push_back({vid(i, j), vid(i + 1, j + 1), vid(i, j + 1)});
          } else {
            m.triangles.push_back({vid(i, j), vid(i + 1, j), vid(i, j + 1)});
            m.triangles.push_back({vid(i + 1, j), vid(i + 1, j + 1), vid(i, j + 1)});
          }
        } else if (!a) {
          m.triangles.push_back({vid(i + 1, j), vid(i + 1, j + 1), vid(i, j + 1)});
        } else if (!b) {
          m.triangles.push_back({vid(i, j), vid(i + 1, j + 1), vid(i, j + 1)});
        } else if (!c) {
          m.triangles.push_back({vid(i, j), vid(i + 1, j), vid(i, j + 1)});
        } else {
          m.triangles.push_back({vid(i, j), vid(i + 1, j), vid(i + 1, j + 1)});
        }
      }
    }
    (void)T;
    if (m.triangles.empty()) continue;
    // Grown by doubling: up to half of each vector is slack, over every tile of the export.
    m.positions.shrink_to_fit();
    m.uvs.shrink_to_fit();
    m.colours.shrink_to_fit();
    m.classes.shrink_to_fit();
    m.triangles.shrink_to_fit();
    out.push_back(std::move(m));
  }
  return out;
}

void writeObj(const std::vector<TileMesh>& tiles, const std::string& dir, const std::string& base) {
  // Streamed: the OBJ text is several times the mesh's size in memory (35 MB for 69 tiles).
  AtomicFileWriter obj((fs::path(dir) / (base + ".obj")).string());
  std::ostringstream mtl;
  std::ostream& out = obj.stream();
  mtl << "# TerraMRF textured terrain mesh: one material per tile\n";
  out << "# TerraMRF textured terrain mesh (paper 004): world frame x forward/north, y left, z up "
         "[m]\n";
  out << "mtllib " << base << ".mtl\n";
  char buf[160];
  auto line = [&](int n) { out.write(buf, std::min<int>(n, sizeof buf - 1)); };
  std::size_t offset = 1;  // OBJ indices are 1-based and global
  for (const TileMesh& m : tiles) {
    const std::string png = "textures/" + m.name + ".png";
    if (m.texture) writeImageAtomic((fs::path(dir) / png).string(), *m.texture);
    mtl << "\nnewmtl " << m.name << "\nKa 1 1 1\nKd 1 1 1\nKs 0 0 0\nillum 1\nmap_Kd " << png
        << "\n";
    out << "\no " << m.name << "\nusemtl " << m.name << "\n";
    for (const auto& p : m.positions)
      line(std::snprintf(buf, sizeof buf, "v %.4f %.4f %.4f\n", p[0], p[1], p[2]));
    for (const auto& uv : m.uvs)
      line(std::snprintf(buf, sizeof buf, "vt %.6f %.6f\n", uv[0], uv[1]));
    for (const auto& t : m.triangles) {
      const std::size_t a = t[0] + offset, b = t[1] + offset, c = t[2] + offset;
      line(std::snprintf(buf, sizeof buf, "f %zu/%zu %zu/%zu %zu/%zu\n", a, a, b, b, c, c));
    }
    offset += m.positions.size();
  }
  writeFileAtomic((fs::path(dir) / (base + ".mtl")).string(), mtl.str());
  obj.commit();
}

void checkWritableFolder(const std::string& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) {
    throw std::runtime_error("mesh output folder '" + dir + "' cannot be created (" +
                             (ec ? ec.message() : std::string("a file of that name exists")) +
                             "); expected a writable folder");
  }
  const std::string probe =
      (fs::path(dir) / (".write_probe_" + std::to_string(::getpid()))).string();
  std::FILE* f = std::fopen(probe.c_str(), "wb");
  if (!f) {
    throw std::runtime_error("mesh output folder '" + dir +
                             "' is not writable; expected a "
                             "writable folder");
  }
  std::fclose(f);
  fs::remove(probe, ec);
}

ExportStats exportMesh(const TerrainMesh& mesh, const std::string& dir,
                       const ExportOptions& options) {
  const fs::path target = fs::absolute(dir).lexically_normal();
  const fs::path parent = target.parent_path();
  checkWritableFolder(parent.string());
  // An export killed mid-way (this folder's name with .tmp-/.old-<its pid>) is never finished or
  // removed by its own process: gone before this one starts, its previous export put back.
  for (const auto& line : removeStaleTemps(parent.string(), 0, target.filename().string()))
    std::fprintf(stderr, "mesh export: %s\n", line.c_str());
  const fs::path tmp = parent / (target.filename().string() + ".tmp-" + std::to_string(::getpid()));
  std::error_code ec;
  fs::remove_all(tmp, ec);
  ExportStats st;
  try {
    fs::create_directories(tmp);
    std::vector<TileMesh> tiles = extractTileMeshes(mesh);
    st.tiles = tiles.size();
    for (auto& m : tiles) {
      st.triangles_before_decimation += m.triangles.size();
      if (options.decimate) {
        const DecimationStats d = decimateTileMesh(m, options.flat_tolerance_m);
        st.max_deviation_m = std::max(st.max_deviation_m, d.max_deviation_m);
      }
      st.vertices += m.positions.size();
      st.triangles += m.triangles.size();
    }
    if (tiles.empty()) {
      // Nothing to write: an empty .glb has a zero-length buffer (invalid glTF) and an empty
      // OBJ/PLY would pass for a mesh. The caller says why (add_files, the log).
    } else if (options.obj) {
      writeObj(tiles, tmp.string(), options.basename);
      st.files.push_back(options.basename + ".obj");
      st.files.push_back(options.basename + ".mtl");
      for (const auto& m : tiles) st.files.push_back("textures/" + m.name + ".png");
    }
    if (options.ply && !tiles.empty()) {
      writePly(tiles, (tmp / (options.basename + ".ply")).string());
      st.files.push_back(options.basename + ".ply");
    }
    if (options.gltf && !tiles.empty()) {
      writeGlb(tiles, (tmp / (options.basename + ".glb")).string());
      st.files.push_back(options.basename + ".glb");
    }
    if (options.add_files) options.add_files(tmp.string(), st);
  } catch (const std::exception& e) {
    fs::remove_all(tmp, ec);
    throw std::runtime_error("mesh export to '" + target.string() +
                             "' failed; the previous export is kept: " + e.what());
  }
  // Swap: old → .old, tmp → target, drop .old. The target is never a half-written folder.
  const fs::path old = parent / (target.filename().string() + ".old-" + std::to_string(::getpid()));
  fs::remove_all(old, ec);
  if (fs::exists(target)) {
    fs::rename(target, old, ec);
    if (ec) {
      fs::remove_all(tmp, ec);
      throw std::runtime_error("mesh export: cannot replace '" + target.string() +
                               "': " + ec.message());
    }
  }
  fs::rename(tmp, target, ec);
  if (ec) {
    const std::string why = ec.message();
    if (fs::exists(old)) fs::rename(old, target, ec);
    throw std::runtime_error("mesh export: cannot move the new export to '" + target.string() +
                             "': " + why);
  }
  fs::remove_all(old, ec);
  return st;
}

}  // namespace terramrf::meshing
