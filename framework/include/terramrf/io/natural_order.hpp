#pragma once
// Frame order of the dataset readers. Scan files are named by frame number, and not every
// dataset pads the numbers: sorted as text, 10.bin comes before 9.bin and frames are read out of
// recording order (poses, times and motion between frames then go backwards). One rule for every
// reader: natural order.
#include <string>
#include <vector>

namespace terramrf {

/// Natural order: runs of digits compare as numbers ("9" < "10"; leading zeros do not count, so
/// "007" and "7" are the same number), everything else character by character. Names that only
/// differ in their zero padding ("007", "7") then fall back to plain text order, so no two
/// different names are equivalent and a sort gives one order.
bool naturalLess(const std::string& a, const std::string& b);

/// Sorts `names` (file names, stems or paths of one folder) in natural order.
void sortNatural(std::vector<std::string>& names);

}  // namespace terramrf
