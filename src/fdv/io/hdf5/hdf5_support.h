#pragma once
/// What the HDF5 reader and writer share: Metavision's event record, an owning handle for HDF5
/// identifiers, the reason HDF5 gave for its last failure, and the filter-plugin search path.
/// Internal to fdv::io.
#include <hdf5.h>

#include <cstdint>
#include <string>
#include <utility>

namespace fdv::hdf5 {

/// Metavision's EventCD record as stored (x u16 @0, y u16 @2, p i16 @4, t i64 @8: 16 bytes). The
/// writer stores it; the reader reads it as it is when a file's type is exactly this, which spares
/// HDF5's field-by-field conversion.
struct CdEvent {
  std::uint16_t x, y;
  std::int16_t p;
  std::int64_t t;
};

/// Owns one HDF5 identifier (file, group, dataset, dataspace, type, property list, attribute)
/// and closes it with H5Idec_ref, which fits every kind.
class Id {
 public:
  Id() = default;
  explicit Id(hid_t id) : id_(id) {}
  Id(Id&& o) noexcept : id_(std::exchange(o.id_, H5I_INVALID_HID)) {}
  Id& operator=(Id&& o) noexcept {
    if (this != &o) {
      reset();
      id_ = std::exchange(o.id_, H5I_INVALID_HID);
    }
    return *this;
  }
  Id(const Id&) = delete;
  Id& operator=(const Id&) = delete;
  ~Id() { reset(); }
  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }
  void reset() {
    if (id_ >= 0) H5Idec_ref(id_);
    id_ = H5I_INVALID_HID;
  }

 private:
  hid_t id_ = H5I_INVALID_HID;
};

/// Stops HDF5 printing its error stack to stderr (this thread): failures become exceptions
/// carrying last_error() instead. Call before any other HDF5 call.
void quiet_errors();
/// The most specific description on HDF5's error stack (e.g. "truncated file: eof = 512, ..."),
/// or "unknown HDF5 error".
std::string last_error();

/// When HDF5_PLUGIN_PATH is unset, appends Debian's filter-plugin folders (hdf5-filter-plugin:
/// LZ4, BZip2, Bitshuffle; hdf5-filter-plugin-blosc-serial: Blosc, and python3-hdf5plugin's
/// folder when it has one) to HDF5's search path, once per process. Returns the search path.
std::string use_default_plugin_path();

/// HDF5 filter id of Prophesee's ECF codec (0x8ECF), which Debian does not ship.
inline constexpr H5Z_filter_t kEcfFilterId = 36559;

/// Throws InputError naming `file`, `dataset` and the filter when a filter of the dataset's
/// pipeline is not available (ECF: how to get a readable file). Returns a note listing them.
std::string check_filters(const std::string& file, const std::string& dataset, hid_t dset);

}  // namespace fdv::hdf5
