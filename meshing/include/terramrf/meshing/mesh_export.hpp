#pragma once
// Exports of the textured terrain mesh: OBJ + MTL + one PNG texture per tile, PLY with per-vertex
// colour and class (CGAL::Surface_mesh), binary glTF 2.0 (.glb, textures embedded; opens in
// browser viewers). All files of one export go to a temporary folder first, which then replaces
// the target folder, so a failing export never replaces a good one. A mesh without a triangle
// writes no mesh files (an empty .glb is not valid glTF): the folder then holds only what
// ExportOptions::add_files writes (the plugin's report.md saying why).
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "terramrf/image.hpp"
#include "terramrf/meshing/terrain_mesh.hpp"

namespace terramrf::meshing {

/// One tile as an indexed triangle mesh, vertices with data only.
struct TileMesh {
  std::string name;                     ///< "tile_<ti>_<tj>" (negative indices as m3 etc.)
  std::vector<std::array<double, 3>> positions;  ///< world [m]
  std::vector<std::array<float, 2>> uvs;         ///< OBJ convention (v up), in [0, 1]
  std::vector<std::array<uint8_t, 3>> colours;   ///< texture colour at the vertex
  std::vector<uint8_t> classes;                  ///< VertexClass
  std::vector<std::array<uint32_t, 3>> triangles;  ///< counter-clockwise seen from above
  const Image* texture = nullptr;
};

/// Triangulates every tile: a cell whose four corners have data gives two triangles (split along
/// the diagonal with the smaller height difference), three corners give one. Only vertices used
/// by a triangle are kept. Tiles without triangles are left out.
std::vector<TileMesh> extractTileMeshes(const TerrainMesh& mesh);

struct ExportStats {
  std::size_t tiles = 0, vertices = 0, triangles = 0;
  std::size_t triangles_before_decimation = 0;  ///< = triangles when not decimated
  double max_deviation_m = 0;                   ///< decimation: bound on the vertical deviation [m]
  std::vector<std::string> files;               ///< relative to the export folder
};

struct ExportOptions {
  bool obj = true;
  bool ply = true;
  bool gltf = true;
  std::string basename = "terrain";  ///< terrain.obj / .mtl / .ply / .glb
  /// Collapse flat regions before writing (decimation.hpp); all formats get the same mesh.
  bool decimate = false;
  double flat_tolerance_m = 0.05;  ///< largest vertical deviation a collapse may cause [m]
  /// Called with the temporary folder after the mesh files are written and before it replaces
  /// the target: what it writes there (report.md) is part of the same all-or-nothing swap.
  std::function<void(const std::string& folder, const ExportStats&)> add_files;
};

/// Largest .glb [bytes]: 2^32 − 1. The container's total length and chunk lengths are uint32;
/// tinygltf truncates larger sizes without a word, so such a file would be written corrupt.
inline constexpr std::uint64_t kMaxGlbBytes = 0xFFFFFFFFull;

/// Size of a .glb with a JSON chunk of `json_bytes` and a binary chunk of `bin_bytes` [bytes]:
/// 12 bytes of header, each chunk with 8 bytes of its own and padded to 4 bytes (no binary
/// chunk when bin_bytes is 0).
std::uint64_t glbFileBytes(std::uint64_t json_bytes, std::uint64_t bin_bytes);

/// Throws std::runtime_error when a .glb of `file_bytes` [bytes] for `tiles` tiles exceeds
/// `max_bytes` (kMaxGlbBytes: what the format can describe), suggesting OBJ/PLY or smaller
/// tiles.
void checkGlbSize(std::uint64_t file_bytes, std::size_t tiles,
                  std::uint64_t max_bytes = kMaxGlbBytes);

/// Writes the selected formats into `dir` (created; its previous content is replaced only when
/// every file was written). Throws std::runtime_error naming the folder and the cause.
ExportStats exportMesh(const TerrainMesh& mesh, const std::string& dir, const ExportOptions& options);

/// Checks that `dir` can be created and written; throws std::runtime_error with a clear message.
void checkWritableFolder(const std::string& dir);

// Writers for one format each (used by exportMesh; `dir` must exist).
void writeObj(const std::vector<TileMesh>& tiles, const std::string& dir, const std::string& base);
void writePly(const std::vector<TileMesh>& tiles, const std::string& path);
/// Writes a .glb; throws std::runtime_error (nothing written) when it would exceed `max_bytes`,
/// JSON, binary chunk and headers together, the embedded PNG textures included.
void writeGlb(const std::vector<TileMesh>& tiles, const std::string& path,
              std::uint64_t max_bytes = kMaxGlbBytes);

}  // namespace terramrf::meshing
