#include "terramrf/run_state.hpp"

#include <stdexcept>

#include "terramrf/params.hpp"

namespace terramrf {

namespace {
std::string geometryText(const GridGeometry& g) {
  return numberText(g.size_m) + " m in cells of " + numberText(g.cell_m) + " m centred at (" +
         numberText(g.centre_m.x()) + ", " + numberText(g.centre_m.y()) + ") m";
}
}  // namespace

TerrainGrid* RunState::findMap(const std::string& name) {
  const auto it = maps.find(name);
  return it == maps.end() ? nullptr : it->second.get();
}

const TerrainGrid* RunState::findMap(const std::string& name) const {
  const auto it = maps.find(name);
  return it == maps.end() ? nullptr : it->second.get();
}

TerrainGrid& RunState::map(const std::string& name, const GridGeometry& geometry) {
  std::shared_ptr<TerrainGrid>& slot = maps[name];
  if (!slot) {
    slot = std::make_shared<TerrainGrid>(geometry);
    return *slot;
  }
  const GridGeometry& have = slot->geometry();
  // Exact: a map is asked for with the geometry its maker stored, not one computed anew.
  if (have.size_m != geometry.size_m || have.cell_m != geometry.cell_m ||
      have.centre_m != geometry.centre_m)
    throw std::invalid_argument("run map '" + name + "' is " + geometryText(have) +
                                ", asked for as " + geometryText(geometry));
  return *slot;
}

}  // namespace terramrf
