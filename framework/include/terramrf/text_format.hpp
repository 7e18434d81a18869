#pragma once
// Quoting for the text formats the outputs and reports write (JSON, CSV), in one place so every
// file escapes names the same way; sizes in messages.
#include <string>
#include <vector>

namespace terramrf {

/// A JSON string literal: `s` in double quotes, with '"' and '\' escaped, '\n' as "\n" and other
/// control characters as \u00XX. Bytes ≥ 0x80 pass through (UTF-8 stays UTF-8).
std::string jsonQuote(const std::string& s);

/// An RFC 4180 CSV field: `s` as is, or in double quotes with inner quotes doubled if it holds a
/// comma, a quote or a line break (\n or \r).
std::string csvField(const std::string& s);

/// A memory or file size for messages, in binary units with three significant digits:
/// "512 bytes", "1.5 KiB", "256 MiB", "45.8 GiB", "1.2 TiB" (`bytes` [bytes], may exceed 2^64).
std::string byteSize(double bytes);

/// Names for messages: "a, b, c", or `empty` when there are none.
std::string joinNames(const std::vector<std::string>& names, const std::string& empty = "none");

}  // namespace terramrf
