# The third-party packages the fdv modules link, found the same way by this project's build and by
# the installed package's fdvConfig.cmake (a downstream project links the static modules, so it
# needs their private dependencies too). Debian package names: DESIGN.md's table.
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
find_package(OpenCV REQUIRED COMPONENTS core imgproc)
find_package(PNG REQUIRED)
find_package(Ceres REQUIRED)
find_package(yaml-cpp REQUIRED)
find_package(nlohmann_json REQUIRED)
find_package(fmt REQUIRED)
find_package(spdlog REQUIRED)
find_package(FlatBuffers REQUIRED)
find_package(SQLite3 REQUIRED)
find_package(BZip2 REQUIRED)
find_package(Threads REQUIRED)
find_package(PkgConfig REQUIRED)
if(NOT TARGET PkgConfig::FDV_LZ4)
  pkg_check_modules(FDV_LZ4 REQUIRED IMPORTED_TARGET GLOBAL liblz4)
  pkg_check_modules(FDV_ZSTD REQUIRED IMPORTED_TARGET GLOBAL libzstd)
  pkg_check_modules(FDV_TINYXML2 REQUIRED IMPORTED_TARGET GLOBAL tinyxml2)
  # HDF5 event files (io/hdf5): Debian's libhdf5-dev, its C library (pkg-config: CMake's FindHDF5
  # would need the C language enabled).
  pkg_check_modules(FDV_HDF5 REQUIRED IMPORTED_TARGET GLOBAL hdf5)
endif()

# ROS 1 bags: Debian's rosbag storage library (librosbag-storage-dev). Its CMake package needs
# ament's Python tooling and its pkg-config file requires a pluginlib.pc that Debian does not
# ship, so the library, its companions and the include folders its headers reach into are found
# directly, as one imported target (the ROS 1 bag tests use it too).
if(NOT TARGET fdv_ros1_storage)
  find_library(FDV_ROSBAG_STORAGE_LIBRARY rosbag_storage REQUIRED)
  set(FDV_ROS1_LIBRARIES ${FDV_ROSBAG_STORAGE_LIBRARY})
  foreach(lib console_bridge rostime roscpp_serialization cpp_common roslz4)
    find_library(FDV_ROS_${lib}_LIBRARY ${lib} REQUIRED)
    list(APPEND FDV_ROS1_LIBRARIES ${FDV_ROS_${lib}_LIBRARY})
  endforeach()
  find_path(FDV_ROSBAG_INCLUDE_DIR rosbag/bag.h REQUIRED)
  set(FDV_ROS1_INCLUDE_DIRS ${FDV_ROSBAG_INCLUDE_DIR})
  # rosbag/bag.h includes pluginlib/class_loader.hpp, which includes class_loader, rcutils,
  # rcpputils and ament_index_cpp headers, each installed one folder deeper than its include name.
  foreach(header pluginlib/class_loader.hpp class_loader/class_loader.hpp rcutils/allocator.h
                 rcpputils/filesystem_helper.hpp ament_index_cpp/get_resource.hpp)
    get_filename_component(pkg ${header} DIRECTORY)
    find_path(FDV_ROS_${pkg}_INCLUDE_DIR ${header} PATH_SUFFIXES ${pkg} REQUIRED)
    list(APPEND FDV_ROS1_INCLUDE_DIRS ${FDV_ROS_${pkg}_INCLUDE_DIR})
  endforeach()
  add_library(fdv_ros1_storage INTERFACE IMPORTED GLOBAL)
  set_target_properties(fdv_ros1_storage PROPERTIES
    INTERFACE_INCLUDE_DIRECTORIES "${FDV_ROS1_INCLUDE_DIRS}"
    INTERFACE_LINK_LIBRARIES "${FDV_ROS1_LIBRARIES}")
endif()
