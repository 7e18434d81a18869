#pragma once
// Where an output plugin may write: a folder inside the run's output folder.
#include <string>

namespace terramrf {

/// Checks an output's `subdir` parameter: non-empty, relative, and without '..', so an output
/// cannot write beside or over another run's results. Throws ParamError("subdir", …) naming what
/// is wrong; `example` is a good value for the message ("grid_csv").
void checkOutputSubdir(const std::string& subdir, const std::string& example);

}  // namespace terramrf
