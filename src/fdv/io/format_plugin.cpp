#include "fdv/io/format_plugin.h"

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <map>
#include <mutex>

#include "fdv/core/error.h"

namespace fdv {
namespace fs = std::filesystem;
namespace {

void add_folder(std::vector<std::string>& out, const fs::path& folder) {
  if (folder.empty()) return;
  const std::string s = folder.lexically_normal().string();
  for (const std::string& seen : out)
    if (seen == s) return;
  out.push_back(s);
}

/// `fdv_plugins` beside an absolute path's file, if the path resolves.
fs::path beside(const char* file) {
  if (file == nullptr || *file == '\0') return {};
  std::error_code ec;
  const fs::path resolved = fs::canonical(file, ec);
  return ec ? fs::path{} : resolved.parent_path() / "fdv_plugins";
}

}  // namespace

const char* plugin_abi() { return FDV_PLUGIN_ABI; }

std::vector<std::string> plugin_search_path() {
  std::vector<std::string> folders;
  if (const char* env = std::getenv("FDV_PLUGIN_PATH")) {
    const std::string list = env;
    for (std::size_t begin = 0; begin <= list.size();) {
      const std::size_t end = std::min(list.find(':', begin), list.size());
      add_folder(folders, list.substr(begin, end - begin));
      begin = end + 1;
    }
  }
  Dl_info self{};
  if (dladdr(reinterpret_cast<void*>(&plugin_search_path), &self) != 0) add_folder(folders, beside(self.dli_fname));
  add_folder(folders, beside("/proc/self/exe"));
  add_folder(folders, FDV_BUILD_PLUGIN_DIR);
  add_folder(folders, FDV_INSTALL_PLUGIN_DIR);
  return folders;
}

namespace {

/// Opens libfdv_NAME.so from the first folder of plugin_search_path() that holds it.
void* open_plugin(const std::string& name, const std::string& needed_for) {
  const std::string file = "libfdv_" + name + ".so";
  std::string tried;
  for (const std::string& folder : plugin_search_path()) {
    const fs::path path = fs::path(folder) / file;
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) {
      tried += (tried.empty() ? "" : ", ") + folder;
      continue;
    }
    void* opened = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (opened == nullptr) {
      const char* why = dlerror();
      throw InputError(needed_for, "", "cannot load the " + name + " plugin " + path.string() + ": " +
                                           (why != nullptr ? why : "unknown reason"));
    }
    const auto abi = reinterpret_cast<const char* (*)()>(dlsym(opened, "fdv_plugin_abi"));
    const std::string built_for = abi != nullptr ? abi() : "(unknown)";
    if (built_for != plugin_abi()) {
      dlclose(opened);
      throw InputError(needed_for, "", "the " + name + " plugin " + path.string() + " was built for fdv " +
                                           built_for + ", not " + plugin_abi() +
                                           ": rebuild it, or set FDV_PLUGIN_PATH to this build's plugins");
    }
    return opened;
  }
  throw InputError(needed_for, "", "needs the " + name + " plugin (" + file + "), found in none of: " + tried +
                                       " (FDV_PLUGIN_PATH adds folders; docs/BUILDING.md \"Format plugins\")");
}

}  // namespace

const void* load_plugin_api(const std::string& name, const char* entry, const std::string& needed_for) {
  static std::mutex mutex;
  static std::map<std::string, void*> loaded;  // never closed: readers it made may outlive any scope
  const std::lock_guard lock(mutex);
  void*& handle = loaded[name];
  if (handle == nullptr) handle = open_plugin(name, needed_for);
  const auto table = reinterpret_cast<const void* (*)()>(dlsym(handle, entry));
  if (table == nullptr)
    throw InputError(needed_for, "", "the " + name + " plugin has no entry " + entry);
  return table();
}

}  // namespace fdv
