#pragma once
// Encoding and decoding of any lcm-gen C++ type to/from MessageBytes, with decode failures turned
// into InputError. Private to terramrf_lcm (templates only; the generated types come from the
// including .cpp).
#include <climits>
#include <exception>
#include <stdexcept>
#include <string>

#include "terramrf/errors.hpp"
#include "terramrf/lcm/message_header.hpp"

namespace terramrf::lcm_detail {

template <class Msg>
MessageBytes encodeMessage(const Msg& msg, const char* type) {
  const int size = msg.getEncodedSize();
  MessageBytes out(static_cast<std::size_t>(size));
  if (size <= 0 || msg.encode(out.data(), 0, size) != size) {
    throw std::runtime_error(std::string("LCM could not encode a terramrf_msgs.") + type +
                             " message (" + std::to_string(size) + " bytes)");
  }
  return out;
}

template <class Msg>
Msg decodeMessage(const void* data, std::size_t size, const std::string& source, const char* type) {
  const std::string what = std::string("terramrf_msgs.") + type;
  if (data == nullptr || size == 0) throw InputError(source, "empty message; expected " + what);
  if (size > static_cast<std::size_t>(INT_MAX)) {
    throw InputError(source, "message of " + std::to_string(size) + " bytes is too large for LCM");
  }
  Msg msg;
  int used = -1;
  try {
    used = msg.decode(data, 0, static_cast<int>(size));
  } catch (const std::exception& e) {
    // Absurd array lengths make the generated code's resize() throw.
    throw InputError(source, "corrupt " + what + " message (" + e.what() + ")");
  }
  if (used < 0) {
    throw InputError(source, "not a " + what + " message (fingerprint mismatch or truncated, " +
                                 std::to_string(size) + " bytes)");
  }
  return msg;
}

}  // namespace terramrf::lcm_detail
