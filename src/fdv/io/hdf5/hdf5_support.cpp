#include "fdv/io/hdf5/hdf5_support.h"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <vector>

#include "fdv/core/error.h"

namespace fdv::hdf5 {

void quiet_errors() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

std::string last_error() {
  std::string deepest;
  H5Ewalk2(
      H5E_DEFAULT, H5E_WALK_DOWNWARD,
      [](unsigned, const H5E_error2_t* e, void* out) -> herr_t {
        if (e->desc && *e->desc) *static_cast<std::string*>(out) = e->desc;
        return 0;
      },
      &deepest);
  return deepest.empty() ? "unknown HDF5 error" : deepest;
}

namespace {
std::vector<std::string> plugin_dirs() {
  std::vector<std::string> dirs;
  unsigned n = 0;
  H5PLsize(&n);
  for (unsigned i = 0; i < n; ++i) {
    char dir[4096] = {};
    if (H5PLget(i, dir, sizeof dir) >= 0) dirs.emplace_back(dir);
  }
  return dirs;
}
}  // namespace

std::string use_default_plugin_path() {
  static std::once_flag once;
  std::call_once(once, [] {
    if (std::getenv("HDF5_PLUGIN_PATH")) return;  // the user's choice wins
    // Debian's libhdf5 may already search its own folder; add what it does not.
    const auto known = plugin_dirs();
    for (const char* dir : {FDV_HDF5_DEBIAN_PLUGIN_DIR, "/usr/lib/python3/dist-packages/hdf5plugin/plugins"})
      if (std::filesystem::is_directory(dir) && std::find(known.begin(), known.end(), dir) == known.end())
        H5PLappend(dir);
  });
  std::string path;
  for (const auto& dir : plugin_dirs()) path += (path.empty() ? "" : ":") + dir;
  return path;
}

std::string check_filters(const std::string& file, const std::string& dataset, hid_t dset) {
  const Id dcpl(H5Dget_create_plist(dset));
  const int n = H5Pget_nfilters(dcpl.get());
  std::string names;
  for (int i = 0; i < n; ++i) {
    unsigned flags = 0, config = 0;
    std::size_t n_values = 0;
    char name[256] = {};
    const H5Z_filter_t id = H5Pget_filter2(dcpl.get(), static_cast<unsigned>(i), &flags, &n_values,
                                           nullptr, sizeof name, name, &config);
    const std::string label = "filter " + std::to_string(id) + (*name ? " (" + std::string(name) + ")" : "");
    names += (names.empty() ? "" : ", ") + label;
    if (H5Zfilter_avail(id) > 0) continue;
    if (id == kEcfFilterId)
      throw InputError(file, "dataset " + dataset,
                       "compressed with Prophesee's ECF codec (HDF5 filter 36559), which Debian does not "
                       "ship: convert the RAW recording instead (`fdv convert REC.raw --to hdf5 OUT.h5`), "
                       "or put Prophesee's hdf5_ecf plugin in HDF5_PLUGIN_PATH");
    throw InputError(file, "dataset " + dataset,
                     label + " is not available: install its plugin (Debian: hdf5-filter-plugin, "
                             "hdf5-filter-plugin-blosc-serial) or point HDF5_PLUGIN_PATH at it; searched '" +
                         use_default_plugin_path() + "'");
  }
  return names.empty() ? "uncompressed" : names;
}

}  // namespace fdv::hdf5
