#pragma once
/// Formats with heavy libraries load them only when such a file is read or written. Their
/// readers and writers are built as plugins, shared objects `libfdv_NAME.so` that fdv::io opens
/// on first use (docs/BUILDING.md, "Format plugins"): HDF5 brings libcurl and a TLS stack, ROS 1's
/// rosbag storage brings roslib, rospack and libpython, about 45 libraries in all that a program
/// reading other formats never needs.
///
/// A plugin exports two C functions: `fdv_plugin_abi()`, returning plugin_abi() as it was built,
/// and its entry, returning a pointer to its table of entry points (a struct of function pointers
/// that the plugin's folder defines). Thread safety: load_plugin_api may be called concurrently.
#include <string>
#include <vector>

namespace fdv {

/// The project version and the tables' revision: a plugin built for another is refused.
const char* plugin_abi();

/// The folders searched for plugins, in order: each of $FDV_PLUGIN_PATH (':'-separated); then
/// `fdv_plugins/` beside the shared object that holds fdv::io (the Python package's `_fdv`) and
/// beside the program; then the build tree's and the install's plugin folders.
std::vector<std::string> plugin_search_path();

/// The table plugin `name` returns from its C function `entry`. Loaded once per process, from
/// the first folder of plugin_search_path() that holds it, and never unloaded (objects it made
/// may live until exit). Throws InputError naming `needed_for` (e.g. the file being opened), the
/// plugin and the folders tried, or the loader's reason.
const void* load_plugin_api(const std::string& name, const char* entry, const std::string& needed_for);

}  // namespace fdv
