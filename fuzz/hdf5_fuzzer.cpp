// An HDF5 event file (Metavision or DSEC layout) as an in-memory image (HDF5's core driver), read
// to its end as `fdv info` reads it; the reader's implementation linked in, not loaded as the plugin.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fdv/io/hdf5/hdf5_plugin_api.h"
#include "fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fdv::fuzz::expect_contract([&] {
    fdv::ReaderOptions options;
    options.width = 640;  // the DSEC layout carries no sensor size
    options.height = 480;
    fdv::fuzz::drain(*fdv::hdf5::open_reader_image(std::string(reinterpret_cast<const char*>(data), size),
                                                   fdv::fuzz::kInputName, options));
  });
  return 0;
}
