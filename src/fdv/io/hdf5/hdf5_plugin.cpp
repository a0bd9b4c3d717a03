// The HDF5 plugin's exports (libfdv_hdf5.so; fdv/io/format_plugin.h).
#include "fdv/io/format_plugin.h"
#include "fdv/io/hdf5/hdf5_plugin_api.h"

extern "C" __attribute__((visibility("default"))) const char* fdv_plugin_abi() { return fdv::plugin_abi(); }

extern "C" __attribute__((visibility("default"))) const void* fdv_hdf5_plugin_api() {
  static const fdv::hdf5::PluginApi api{&fdv::hdf5::open_reader, &fdv::hdf5::open_reader_image,
                                        &fdv::hdf5::create_writer};
  return &api;
}
