#include "terramrf/io/natural_order.hpp"

#include <algorithm>

namespace terramrf {
namespace {

bool isDigit(char c) { return c >= '0' && c <= '9'; }

}  // namespace

bool naturalLess(const std::string& a, const std::string& b) {
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (!isDigit(a[i]) || !isDigit(b[j])) {
      // A digit against another character compares as text: every digit run then sorts the
      // same way against that character, which keeps the order consistent.
      if (a[i] != b[j]) return static_cast<unsigned char>(a[i]) < static_cast<unsigned char>(b[j]);
      ++i;
      ++j;
      continue;
    }
    std::size_t a_end = i, b_end = j;
    while (a_end < a.size() && isDigit(a[a_end])) ++a_end;
    while (b_end < b.size() && isDigit(b[b_end])) ++b_end;
    // Compared as digit strings without their leading zeros (one kept for 0): the longer is the
    // larger number, equal lengths compare digit by digit. No integer conversion, so any length
    // of run works (RELLIS-style ids may be longer than 64 bits).
    while (i + 1 < a_end && a[i] == '0') ++i;
    while (j + 1 < b_end && b[j] == '0') ++j;
    const std::size_t a_len = a_end - i, b_len = b_end - j;
    if (a_len != b_len) return a_len < b_len;
    if (const int c = a.compare(i, a_len, b, j, b_len); c != 0) return c < 0;
    i = a_end;
    j = b_end;
  }
  if (i < a.size() || j < b.size()) return j < b.size();  // a prefix of the other comes first
  return a < b;  // the same but for zero padding: text order decides
}

void sortNatural(std::vector<std::string>& names) {
  std::sort(names.begin(), names.end(), naturalLess);
}

}  // namespace terramrf
