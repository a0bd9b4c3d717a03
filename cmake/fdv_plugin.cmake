# fdv_add_format_plugin(NAME IMPLEMENTATION file.cpp... ENTRY file.cpp [LINK target...])
#
# A format whose library is heavy, loaded only when used (src/fdv/io/format_plugin.h):
#  - fdv_NAME_impl, a static library of the implementation over LINK; the fuzz targets that
#    reach inside it link it directly;
#  - fdv_plugin_NAME, the shared object libfdv_NAME.so (the implementation and its ENTRY, which
#    exports the C functions fdv::io looks up), in BUILD/fdv_plugins and, installed, in
#    LIBDIR/fdv. The fdv code it carries is its own copy: none of it is exported or interposed.
# Everything that may open such a file depends on the target fdv_plugins, which builds them all.
function(fdv_add_format_plugin name)
  cmake_parse_arguments(arg "" "ENTRY" "IMPLEMENTATION;LINK" ${ARGN})
  set(impl fdv_${name}_impl)
  add_library(${impl} STATIC ${arg_IMPLEMENTATION})
  set_target_properties(${impl} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  target_link_libraries(${impl} PUBLIC ${arg_LINK} PRIVATE $<BUILD_INTERFACE:fdv_warnings>)
  if(FDV_FUZZ)
    target_compile_options(${impl} PRIVATE -fsanitize=fuzzer-no-link)
  endif()

  set(plugin fdv_plugin_${name})
  add_library(${plugin} MODULE ${arg_ENTRY})
  set_target_properties(${plugin} PROPERTIES OUTPUT_NAME fdv_${name}
                                             LIBRARY_OUTPUT_DIRECTORY ${FDV_PLUGIN_BUILD_DIR})
  target_link_libraries(${plugin} PRIVATE ${impl} fdv::io fdv_warnings)
  target_link_options(${plugin} PRIVATE -Wl,--exclude-libs,ALL -Wl,--as-needed)
  if(NOT FDV_SANITIZE)  # a sanitized module leaves the runtime's symbols to the program
    target_link_options(${plugin} PRIVATE -Wl,--no-undefined)
  endif()
  add_dependencies(fdv_plugins ${plugin})
  install(TARGETS ${plugin} LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}/fdv)
endfunction()
