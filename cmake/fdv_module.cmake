# fdv_add_module(NAME SOURCES file.cpp... [DEPENDS target...] [PRIVATE_DEPENDS target...])
#
# One static library per module folder, `fdv_NAME`, aliased and exported as `fdv::NAME`. The
# module's headers are reachable as "fdv/NAME/..." only through its own include root (a folder in
# the build tree holding one link, fdv/NAME -> this source folder), which reaches a dependent
# target only through DEPENDS. So an include of a module that is not a dependency fails to
# compile: the build enforces DESIGN.md's arrows.
function(fdv_add_module name)
  cmake_parse_arguments(arg "" "" "SOURCES;DEPENDS;PRIVATE_DEPENDS" ${ARGN})
  set(target fdv_${name})
  add_library(${target} STATIC ${arg_SOURCES})
  add_library(fdv::${name} ALIAS ${target})
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${name} POSITION_INDEPENDENT_CODE ON)

  set(root ${CMAKE_BINARY_DIR}/include_roots/${name})
  file(MAKE_DIRECTORY ${root}/fdv)
  if(NOT EXISTS ${root}/fdv/${name})
    file(CREATE_LINK ${CMAKE_CURRENT_SOURCE_DIR} ${root}/fdv/${name} SYMBOLIC)
  endif()
  target_include_directories(${target} PUBLIC $<BUILD_INTERFACE:${root}> $<INSTALL_INTERFACE:include>)
  target_link_libraries(${target} PUBLIC ${arg_DEPENDS}
                                  PRIVATE $<BUILD_INTERFACE:fdv_warnings> ${arg_PRIVATE_DEPENDS})
  if(FDV_FUZZ)
    # Coverage feedback for the fuzzer from the library's code (the readers and parsers it drives).
    target_compile_options(${target} PRIVATE -fsanitize=fuzzer-no-link)
  endif()

  install(TARGETS ${target} EXPORT fdvTargets ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
  install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/fdv/${name}
          FILES_MATCHING PATTERN "*.h" PATTERN "reference_*.h" EXCLUDE)
  set_property(GLOBAL APPEND PROPERTY FDV_MODULES ${name})
  # The module's arrows, for the test that README's module table draws the graph as built.
  set(uses)
  foreach(dep ${arg_DEPENDS})
    if(dep MATCHES "^fdv::(.+)$")
      list(APPEND uses ${CMAKE_MATCH_1})
    endif()
  endforeach()
  list(JOIN uses "," uses)
  set_property(GLOBAL APPEND PROPERTY FDV_MODULE_GRAPH "${name}:${uses}")
endfunction()
