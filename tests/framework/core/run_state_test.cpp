#include "terramrf/run_state.hpp"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

namespace terramrf {

// A map is made once, with its maker's geometry, and then found by name with its layers; asked
// for with another geometry it is refused by name, not handed out to be written past its cells.
TEST(RunState, AMapIsMadeOnceAndRefusedUnderAnotherGeometry) {
  RunState run;
  EXPECT_EQ(run.findMap("map.semantic"), nullptr);
  GridGeometry g;
  g.size_m = 100;
  g.cell_m = 0.5;
  TerrainGrid& m = run.map("map.semantic", g);
  EXPECT_EQ(m.cells(), 200u * 200u);
  m.add("hits", 0.f)[7] = 3.f;
  EXPECT_EQ(&run.map("map.semantic", g), &m);
  EXPECT_EQ(run.findMap("map.semantic"), &m);
  EXPECT_EQ(static_cast<const RunState&>(run).findMap("map.semantic")->layer("hits")[7], 3.f);
  EXPECT_EQ(run.findMap("map.other"), nullptr);

  GridGeometry finer = g;
  finer.cell_m = 0.25;
  GridGeometry moved = g;
  moved.centre_m.x() = 10;
  for (const GridGeometry& other : {finer, moved}) {
    try {
      run.map("map.semantic", other);
      ADD_FAILURE() << "expected the other geometry to be refused";
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()).rfind(
                    "run map 'map.semantic' is 100 m in cells of 0.5 m centred at (0, 0) m, asked "
                    "for as ",
                    0),
                0u)
          << e.what();
    }
  }
  EXPECT_EQ(run.findMap("map.semantic")->layer("hits")[7], 3.f);  // untouched by the refusals
  EXPECT_EQ(run.maps.size(), 1u);
}

}  // namespace terramrf
