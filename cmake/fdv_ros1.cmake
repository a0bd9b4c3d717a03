# ROS 1 (Debian bookworm's roscpp 1.15 and gencpp): the live node and the ROS 1 bag export, in ros/.
# Debian ships no catkin workspace for plain CMake, so the pieces are found directly:
#   fdv_roscpp      roscpp, topic_tools and their companions, for a node to link;
#   fdv_ros1_msgs   the headers generated from our .msg files (fdv_ros1_add_messages) and the
#                   ROS include folders.
# Debian's generated ROS headers do not compile as C++20 (std::allocator<void>::rebind), so every
# target that includes a ROS header is built with CXX_STANDARD 17 and sees no C++20 fdv header.
#
#   fdv_ros1_add_messages(dvs_msgs ${CMAKE_CURRENT_SOURCE_DIR}/msg/dvs_msgs)
#   target_link_libraries(my_node PRIVATE fdv_ros1_msgs fdv_roscpp)
#   set_target_properties(my_node PROPERTIES CXX_STANDARD 17)
option(FDV_ROS1 "Build the ROS 1 node and bag export when Debian's ROS 1 packages are found" ON)

set(FDV_ROS1_MSG_INCLUDE_DIR ${CMAKE_BINARY_DIR}/ros/include)

if(FDV_ROS1)
  set(fdv_ros1_missing "")
  # gencpp's generator runs on Debian's interpreter, which has the genmsg/gencpp modules.
  find_program(FDV_ROS1_PYTHON python3 PATHS /usr/bin NO_DEFAULT_PATH)
  find_program(FDV_ROS1_GENCPP gen_cpp.py PATHS /usr/lib/gencpp NO_DEFAULT_PATH)
  find_path(FDV_ROS1_GENCPP_TEMPLATES msg.h.template PATHS /usr/share/gencpp NO_DEFAULT_PATH)
  find_path(FDV_ROS1_STD_MSGS_DIR Header.msg PATHS /usr/share/std_msgs/msg NO_DEFAULT_PATH)
  find_path(FDV_ROS1_GEOMETRY_MSGS_DIR Point.msg PATHS /usr/share/geometry_msgs/msg NO_DEFAULT_PATH)
  find_path(FDV_ROS1_ROSCPP_INCLUDE_DIR ros/ros.h)
  find_path(FDV_ROS1_TOPIC_TOOLS_INCLUDE_DIR topic_tools/shape_shifter.h)
  foreach(var FDV_ROS1_PYTHON FDV_ROS1_GENCPP FDV_ROS1_GENCPP_TEMPLATES FDV_ROS1_STD_MSGS_DIR
              FDV_ROS1_GEOMETRY_MSGS_DIR FDV_ROS1_ROSCPP_INCLUDE_DIR FDV_ROS1_TOPIC_TOOLS_INCLUDE_DIR)
    if(NOT ${var})
      list(APPEND fdv_ros1_missing ${var})
    endif()
  endforeach()
  if(FDV_ROS1_PYTHON AND FDV_ROS1_GENCPP)
    execute_process(COMMAND ${FDV_ROS1_PYTHON} -c "import genmsg, gencpp"
                    RESULT_VARIABLE fdv_ros1_py_result OUTPUT_QUIET ERROR_QUIET)
    if(NOT fdv_ros1_py_result EQUAL 0)
      list(APPEND fdv_ros1_missing "python modules genmsg/gencpp")
    endif()
  endif()
  set(fdv_ros1_libraries "")
  foreach(lib roscpp topic_tools rosconsole roscpp_serialization rostime cpp_common xmlrpcpp
              boost_system boost_thread boost_chrono boost_filesystem)
    find_library(FDV_ROS1_${lib}_LIBRARY ${lib})
    if(FDV_ROS1_${lib}_LIBRARY)
      list(APPEND fdv_ros1_libraries ${FDV_ROS1_${lib}_LIBRARY})
    else()
      list(APPEND fdv_ros1_missing lib${lib})
    endif()
  endforeach()

  if(fdv_ros1_missing)
    message(STATUS "ROS 1: off, missing ${fdv_ros1_missing} (scripts/setup.sh installs the "
                   "ROS packages; -DFDV_ROS1=OFF silences this)")
    set(FDV_ROS1 OFF)
  else()
    message(STATUS "ROS 1: on (roscpp ${FDV_ROS1_roscpp_LIBRARY}, messages generated into "
                   "${FDV_ROS1_MSG_INCLUDE_DIR})")
    add_library(fdv_roscpp INTERFACE IMPORTED GLOBAL)
    set_target_properties(fdv_roscpp PROPERTIES
      INTERFACE_INCLUDE_DIRECTORIES "${FDV_ROS1_ROSCPP_INCLUDE_DIR};${FDV_ROS1_TOPIC_TOOLS_INCLUDE_DIR}"
      INTERFACE_LINK_LIBRARIES "${fdv_ros1_libraries};Threads::Threads")

    # SYSTEM: the generated headers are ROS's code, not ours, so our -Werror warnings skip them.
    file(MAKE_DIRECTORY ${FDV_ROS1_MSG_INCLUDE_DIR})
    add_library(fdv_ros1_msgs INTERFACE)
    target_include_directories(fdv_ros1_msgs SYSTEM INTERFACE ${FDV_ROS1_MSG_INCLUDE_DIR}
                               ${FDV_ROS1_ROSCPP_INCLUDE_DIR})
    add_custom_target(fdv_ros1_msgs_generate)
    add_dependencies(fdv_ros1_msgs fdv_ros1_msgs_generate)
    # Message folders gen_cpp.py may resolve types in: Debian's, then each fdv_ros1_add_messages.
    set_property(GLOBAL PROPERTY FDV_ROS1_MSG_PATHS
                 std_msgs:${FDV_ROS1_STD_MSGS_DIR} geometry_msgs:${FDV_ROS1_GEOMETRY_MSGS_DIR})
  endif()
endif()

# fdv_ros1_add_messages(<package> <msg_dir>)
# Generates ${FDV_ROS1_MSG_INCLUDE_DIR}/<package>/<Type>.h from every <msg_dir>/*.msg with gencpp,
# again whenever a .msg of <package> (or of a package added before it) changes, and adds them to
# fdv_ros1_msgs. Types of std_msgs, geometry_msgs and of packages added earlier may be used.
function(fdv_ros1_add_messages package msg_dir)
  file(GLOB msgs CONFIGURE_DEPENDS ${msg_dir}/*.msg)
  if(NOT msgs)
    message(FATAL_ERROR "fdv_ros1_add_messages(${package}): no .msg file in ${msg_dir}")
  endif()
  set_property(GLOBAL APPEND PROPERTY FDV_ROS1_MSG_PATHS ${package}:${msg_dir})
  get_property(paths GLOBAL PROPERTY FDV_ROS1_MSG_PATHS)
  # A message embeds the md5 of the types it uses, so each header depends on every repo .msg
  # visible to its package.
  set_property(GLOBAL APPEND PROPERTY FDV_ROS1_MSG_FILES ${msgs})
  get_property(all_msgs GLOBAL PROPERTY FDV_ROS1_MSG_FILES)
  set(include_args "")
  foreach(path ${paths})
    list(APPEND include_args -I ${path})
  endforeach()
  set(outputs "")
  foreach(msg ${msgs})
    get_filename_component(type ${msg} NAME_WE)
    set(out ${FDV_ROS1_MSG_INCLUDE_DIR}/${package}/${type}.h)
    add_custom_command(
      OUTPUT ${out}
      COMMAND ${FDV_ROS1_PYTHON} ${FDV_ROS1_GENCPP} ${msg} -p ${package}
              -o ${FDV_ROS1_MSG_INCLUDE_DIR}/${package} -e ${FDV_ROS1_GENCPP_TEMPLATES} ${include_args}
      DEPENDS ${all_msgs} ${FDV_ROS1_GENCPP} ${FDV_ROS1_GENCPP_TEMPLATES}/msg.h.template
      COMMENT "gencpp ${package}/${type}"
      VERBATIM)
    list(APPEND outputs ${out})
  endforeach()
  add_custom_target(fdv_ros1_${package}_generate DEPENDS ${outputs})
  add_dependencies(fdv_ros1_msgs_generate fdv_ros1_${package}_generate)
endfunction()
