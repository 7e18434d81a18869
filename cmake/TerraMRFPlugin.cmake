# terramrf_add_plugin(NAME <type> SOURCES <files...> [LIBRARIES <libs...>])
#
# Builds one plugin shared library `terramrf_<type>.so` against the framework and places it
# where the CLI looks (the build's / install's plugin folder, or the current binary folder for
# out-of-tree builds).
function(terramrf_add_plugin)
  cmake_parse_arguments(P "" "NAME" "SOURCES;LIBRARIES" ${ARGN})
  if(NOT P_NAME OR NOT P_SOURCES)
    message(FATAL_ERROR "terramrf_add_plugin: NAME and SOURCES are required")
  endif()
  set(_target terramrf_plugin_${P_NAME})
  add_library(${_target} MODULE ${P_SOURCES})
  if(TARGET terramrf::framework)
    target_link_libraries(${_target} PRIVATE terramrf::framework ${P_LIBRARIES})
  else()
    target_link_libraries(${_target} PRIVATE terramrf_framework ${P_LIBRARIES})
  endif()
  set_target_properties(${_target} PROPERTIES
    PREFIX "" OUTPUT_NAME "terramrf_${P_NAME}"
    CXX_VISIBILITY_PRESET hidden VISIBILITY_INLINES_HIDDEN ON)
  if(TERRAMRF_PLUGIN_OUTPUT_DIR)  # in-tree build
    set_target_properties(${_target} PROPERTIES LIBRARY_OUTPUT_DIRECTORY ${TERRAMRF_PLUGIN_OUTPUT_DIR}
      INSTALL_RPATH "$ORIGIN/../..")
    install(TARGETS ${_target} LIBRARY DESTINATION ${TERRAMRF_PLUGIN_SUBDIR})
  endif()
endfunction()
