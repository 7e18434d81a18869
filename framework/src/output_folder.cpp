#include "terramrf/output_folder.hpp"

#include <filesystem>

#include "terramrf/errors.hpp"

namespace terramrf {

void checkOutputSubdir(const std::string& subdir, const std::string& example) {
  if (subdir.empty())
    throw ParamError("subdir", "is empty; expected a folder name such as '" + example + "'");
  const std::filesystem::path p(subdir);
  if (p.is_absolute())
    throw ParamError("subdir", "'" + subdir +
                                   "' is absolute; expected a folder relative to the run's output "
                                   "folder, such as '" +
                                   example + "'");
  for (const auto& part : p)
    if (part == "..")
      throw ParamError("subdir", "'" + subdir +
                                     "' leaves the run's output folder ('..'); expected a folder "
                                     "inside it, such as '" +
                                     example + "'");
}

}  // namespace terramrf
