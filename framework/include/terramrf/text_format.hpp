#pragma once
// Quoting for the text formats the outputs and reports write (JSON, CSV), in one place so every
// file escapes names the same way.
#include <string>

namespace terramrf {

/// A JSON string literal: `s` in double quotes, with '"' and '\' escaped, '\n' as "\n" and other
/// control characters as \u00XX. Bytes ≥ 0x80 pass through (UTF-8 stays UTF-8).
std::string jsonQuote(const std::string& s);

/// An RFC 4180 CSV field: `s` as is, or in double quotes with inner quotes doubled if it holds a
/// comma, a quote or a line break (\n or \r).
std::string csvField(const std::string& s);

}  // namespace terramrf
