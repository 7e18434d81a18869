# Compiles one file on its own (no build of the tree: ctest may run beside a build) and passes
# only if the compiler refuses it with MESSAGE in its output.
# -DCXX=compiler -DSRC=file -DINCLUDES="dir;dir" -DMESSAGE=text
set(_args -std=c++17 -fsyntax-only)
foreach(_d IN LISTS INCLUDES)
  list(APPEND _args -I${_d})
endforeach()
execute_process(COMMAND ${CXX} ${_args} ${SRC} RESULT_VARIABLE _rc OUTPUT_VARIABLE _out
  ERROR_VARIABLE _out)
if(_rc EQUAL 0)
  message(FATAL_ERROR "${SRC} compiled; expected the compiler to refuse it with '${MESSAGE}'")
endif()
string(FIND "${_out}" "${MESSAGE}" _at)
if(_at EQUAL -1)
  message(FATAL_ERROR "${SRC} was refused, but not with '${MESSAGE}':\n${_out}")
endif()
message(STATUS "refused as expected: ${MESSAGE}")
