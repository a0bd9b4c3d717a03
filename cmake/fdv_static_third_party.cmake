# The program `fdv` links its third-party libraries from Debian's static archives where the -dev
# packages ship them (docs/BENCHMARKS.md, "Start-up and shared libraries"): every shared library
# costs each start its mapping, page faults, relocations and a place in every symbol lookup, and
# `fdv` is started hundreds of times by the tests, `dodge-eval` and a planner. Everything else (the
# tests, the Python module, the plugins, a user's program through the installed package) links
# the shared libraries as before.
#
#   fdv_static_alternative(<target> ARCHIVES <name>... [LINK <library>...])
#     <target>'s static alternative: its usage requirements with the archives lib<name>.a (in link
#     order) and what they need (targets, or shared libraries by name or file name, "a|b" for
#     either), when every archive and library is found; otherwise none, and the program links the
#     shared library.
#   fdv_prefer_static(<target>... [SELF])
#     Rewrites each target's link interface (SELF: its own link libraries) so that a target with
#     the property FDV_STATIC_THIRD_PARTY links the alternatives. Decided per consumer, at generation.
option(FDV_STATIC_THIRD_PARTY "Link the fdv program's third-party libraries from static archives where they exist" ON)

function(fdv_static_alternative target)
  cmake_parse_arguments(arg "" "" "ARCHIVES;LINK" ${ARGN})
  if(NOT FDV_STATIC_THIRD_PARTY OR NOT TARGET ${target})
    return()
  endif()
  set(libraries)
  foreach(name ${arg_ARCHIVES})
    find_library(FDV_STATIC_${name} NAMES lib${name}.a NO_CACHE)
    if(NOT FDV_STATIC_${name})
      message(STATUS "fdv: no static lib${name}.a: ${target} stays shared in fdv")
      return()
    endif()
    list(APPEND libraries ${FDV_STATIC_${name}})
  endforeach()
  foreach(library ${arg_LINK})
    if(NOT TARGET ${library})
      # A shared library: the name the linker knows, or else its file's name ("GLX|libGLX.so.0": a
      # sysroot may have the runtime package without the -dev link).
      string(REPLACE "|" ";" names "${library}")
      string(MAKE_C_IDENTIFIER "FDV_SHARED_${library}" found)
      find_library(${found} NAMES ${names} NO_CACHE)
      if(NOT ${found})
        message(STATUS "fdv: no ${library} for the static ${target}: it stays shared in fdv")
        return()
      endif()
      set(library ${${found}})
    endif()
    list(APPEND libraries ${library})
  endforeach()
  string(MAKE_C_IDENTIFIER "fdv_static_${target}" alternative)
  add_library(${alternative} INTERFACE IMPORTED)
  foreach(property INTERFACE_INCLUDE_DIRECTORIES INTERFACE_SYSTEM_INCLUDE_DIRECTORIES
                   INTERFACE_COMPILE_DEFINITIONS INTERFACE_COMPILE_OPTIONS INTERFACE_COMPILE_FEATURES)
    get_target_property(value ${target} ${property})
    if(value)
      set_property(TARGET ${alternative} PROPERTY ${property} "${value}")
    endif()
  endforeach()
  set_property(TARGET ${alternative} PROPERTY INTERFACE_LINK_LIBRARIES "${libraries}")
  set_property(GLOBAL APPEND PROPERTY FDV_STATIC_ALTERNATIVES ${target})
  set_property(GLOBAL APPEND PROPERTY FDV_STATIC_ARCHIVES ${arg_ARCHIVES})
endfunction()

function(fdv_prefer_static)
  cmake_parse_arguments(arg "SELF" "" "" ${ARGN})
  get_property(alternatives GLOBAL PROPERTY FDV_STATIC_ALTERNATIVES)
  set(property INTERFACE_LINK_LIBRARIES)
  if(arg_SELF)
    set(property LINK_LIBRARIES)
  endif()
  foreach(target ${arg_UNPARSED_ARGUMENTS})
    get_target_property(items ${target} ${property})
    if(NOT items)
      continue()
    endif()
    set(rewritten)
    foreach(item ${items})
      set(wrap "")
      set(name ${item})
      if(item MATCHES "^\\$<LINK_ONLY:(.+)>$")  # a static library's private dependency
        set(wrap LINK_ONLY)
        set(name ${CMAKE_MATCH_1})
      endif()
      if(name IN_LIST alternatives)
        string(MAKE_C_IDENTIFIER "fdv_static_${name}" alternative)
        set(choice "$<IF:$<BOOL:$<TARGET_PROPERTY:FDV_STATIC_THIRD_PARTY>>,${alternative},${name}>")
        if(wrap)
          set(choice "$<${wrap}:${choice}>")
          set(name "$<${wrap}:${name}>")
        endif()
        # The installed package's consumers link the shared libraries.
        list(APPEND rewritten "$<BUILD_INTERFACE:${choice}>" "$<INSTALL_INTERFACE:${name}>")
      else()
        list(APPEND rewritten "${item}")
      endif()
    endforeach()
    set_property(TARGET ${target} PROPERTY ${property} "${rewritten}")
  endforeach()
endfunction()

# What Debian's archives need beside them (found by linking `fdv`; the shared libraries record it
# themselves). OpenCV's core reaches OpenGL's loader through its OpenGL interop, BLAS/LAPACK through
# its solvers and TBB through its thread pool.
fdv_static_alternative(opencv_core ARCHIVES opencv_core LINK lapack blas tbb z GLX|libGLX.so.0 Threads::Threads)
fdv_static_alternative(opencv_imgproc ARCHIVES opencv_imgproc opencv_core
                       LINK lapack blas tbb z GLX|libGLX.so.0 Threads::Threads)
# Ceres is static already; its logging (glog, gflags) and sparse solvers (SuiteSparse) are not.
fdv_static_alternative(Ceres::ceres
  ARCHIVES ceres glog gflags spqr cholmod cxsparse amd camd colamd ccolamd suitesparseconfig
  LINK unwind|libunwind.so.8 libmetis.so.5 lapack f77blas atlas blas libgomp.so.1 Threads::Threads Eigen3::Eigen)
fdv_static_alternative(yaml-cpp ARCHIVES yaml-cpp)
fdv_static_alternative(PNG::PNG ARCHIVES png16 LINK z)
fdv_static_alternative(PkgConfig::FDV_ZSTD ARCHIVES zstd)
fdv_static_alternative(PkgConfig::FDV_LZ4 ARCHIVES lz4)
fdv_static_alternative(SQLite::SQLite3 ARCHIVES sqlite3 LINK Threads::Threads)
