#include <iostream>

#include "commands.hpp"

namespace terramrf::cli {

int cmdSimulate(const Args&) {
  std::cerr << "terramrf simulate: not built yet\n";
  return kError;
}

}  // namespace terramrf::cli
