// fdv::io's side of HDF5: the public functions and writer, forwarding to the HDF5 plugin
// (hdf5_plugin_api.h), so that only a program touching an HDF5 file loads libhdf5.
#include "fdv/core/error.h"
#include "fdv/io/format_plugin.h"
#include "fdv/io/hdf5/hdf5_plugin_api.h"
#include "fdv/io/hdf5/hdf5_reader.h"
#include "fdv/io/hdf5/hdf5_writer.h"

namespace fdv {
namespace {

const hdf5::PluginApi& hdf5_plugin(const std::string& needed_for) {
  return *static_cast<const hdf5::PluginApi*>(load_plugin_api(hdf5::kPluginName, hdf5::kPluginEntry, needed_for));
}

}  // namespace

bool looks_like_hdf5(std::string_view head) { return head.starts_with(kHdf5Magic); }

std::unique_ptr<RecordingReader> open_hdf5(const std::string& path, const ReaderOptions& options) {
  return hdf5_plugin(path).open(path, options);
}

std::unique_ptr<RecordingReader> open_hdf5_image(std::string image, const std::string& name,
                                                 const ReaderOptions& options) {
  return hdf5_plugin(name).open_image(std::move(image), name, options);
}

std::string Hdf5WriterOptions::validate() const {
  if (gzip_level < 0 || gzip_level > 9) return "gzip_level must be 0..9, got " + std::to_string(gzip_level);
  if (chunk_rows == 0) return "chunk_rows must be > 0";
  return {};
}

Hdf5EventWriter::Hdf5EventWriter(const std::string& path, int width, int height,
                                 const Hdf5WriterOptions& options) {
  if (const std::string why = options.validate(); !why.empty()) throw ConfigError("Hdf5WriterOptions: " + why);
  if (width < 1 || height < 1 || width > 65536 || height > 65536)
    throw ConfigError(path + ": HDF5 (Metavision layout) holds pixels as uint16: sensor size " +
                      std::to_string(width) + "x" + std::to_string(height) + " is outside 1..65536");
  backend_ = hdf5_plugin(path).create_writer(path, width, height, options);
}

Hdf5EventWriter::~Hdf5EventWriter() {
  try {
    close();
  } catch (...) {  // a destructor must not throw; close() explicitly to see the error
  }
}

void Hdf5EventWriter::add(std::span<const Event> events) { backend_->add(events); }
void Hdf5EventWriter::close() { backend_->close(); }
std::uint64_t Hdf5EventWriter::events() const { return backend_->events(); }
std::uint64_t Hdf5EventWriter::floored_events() const { return backend_->floored_events(); }

}  // namespace fdv
