#include <algorithm>
#include <cctype>
#include <iostream>
#include <stdexcept>

#include "commands.hpp"

namespace terramrf::cli {

std::string takeOption(Args& args, const std::string& name) {
  for (std::size_t i = 0; i < args.size(); ++i) {
    std::string v;
    if (args[i] == name) {
      if (i + 1 >= args.size()) throw UsageError("option " + name + " needs a value");
      v = args[i + 1];
      args.erase(args.begin() + i, args.begin() + i + 2);
    } else if (args[i].rfind(name + "=", 0) == 0) {
      v = args[i].substr(name.size() + 1);
      args.erase(args.begin() + i);
    } else {
      continue;
    }
    if (v.empty()) throw UsageError("option " + name + " needs a value, got an empty one");
    return v;
  }
  return "";
}

bool takeCount(Args& args, const std::string& name, const char* command, std::size_t min,
               std::size_t& out) {
  const std::string v = takeOption(args, name);
  if (v.empty()) return true;
  const bool digits = std::all_of(v.begin(), v.end(), [](unsigned char c) { return std::isdigit(c); });
  std::size_t n = 0;
  bool ok = digits;
  if (ok) {
    try {
      n = std::stoull(v);
    } catch (const std::out_of_range&) {
      ok = false;
    }
  }
  if (!ok || n < min) {
    std::cerr << "terramrf " << command << ": " << name << ": expected a whole number >= " << min
              << ", got '" << v << "'\n";
    return false;
  }
  out = n;
  return true;
}

bool takeFlag(Args& args, const std::string& name) {
  auto it = std::find(args.begin(), args.end(), name);
  if (it == args.end()) return false;
  args.erase(it);
  return true;
}

}  // namespace terramrf::cli
