# Run after lcm-gen (messages/CMakeLists.txt): makes the generated C++ decoders refuse malformed
# lengths instead of trusting them. lcm-gen 1.3's _decodeNoHash checks that a string's length
# fits the buffer but not that it is positive, so a length of 0 makes `assign(p, len - 1)` read
# SIZE_MAX bytes, and a negative one moves `pos` backwards; and it resizes arrays to the count
# the message states before checking that the buffer holds them, so a damaged count allocates
# gigabytes or throws. Found by tools/fuzz/fuzz_inputs.py (mode lcm: a damaged log crashed
# `lcm_log` with SIGSEGV). The patterns are lcm-gen's own; a header they no longer match is an
# error here, so a new lcm-gen cannot drop the checks unnoticed.
#
# Usage: cmake -DHEADERS="a.hpp;b.hpp" -P harden_decoders.cmake
foreach(_h ${HEADERS})
  file(READ ${_h} _text)
  if(_text MATCHES "TERRAMRF: decoders hardened")
    continue()
  endif()
  set(_before "${_text}")
  # Strings: a length must count at least the terminating NUL.
  string(REGEX REPLACE "if\\((__[A-Za-z0-9_]+) > maxlen - pos\\) return -1;"
         "if(\\1 <= 0 || \\1 > maxlen - pos) return -1;" _text "${_text}")
  # Arrays: a count must be non-negative and at most the message's length in bytes, before
  # anything is allocated for it. Every element takes at least a byte, except the rows of a 2-D
  # array of empty rows, which the bound still lets through: it caps memory, not validity.
  string(REGEX REPLACE "\n( +)(this->[A-Za-z0-9_]+(\\[a[0-9]+\\])?\\.resize\\(this->([A-Za-z0-9_]+)\\);)"
         "\n\\1if(this->\\4 < 0 || this->\\4 > maxlen) return -1;\n\\1\\2" _text "${_text}")
  if(_text MATCHES "resize\\(" AND _text STREQUAL _before)
    message(FATAL_ERROR "harden_decoders: ${_h}: lcm-gen's decoder patterns not found")
  endif()
  file(WRITE ${_h} "// TERRAMRF: decoders hardened by messages/harden_decoders.cmake\n${_text}")
endforeach()
