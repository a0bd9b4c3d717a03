#pragma once
/// What every fuzz target checks: the input parsers' contract (docs/FORMATS.md "Bad input").
/// A malformed input may end in fdv::InputError naming the input, or in fdv::ConfigError naming
/// it; that is a correct answer. Anything else is a finding, and escapes to libFuzzer, which
/// reports it as a crash: another exception, an error that names no file, a sanitizer report, a
/// timeout (-timeout) or an allocation over -rss_limit_mb.
#include <cstdio>
#include <cstdlib>
#include <string>

#include "fdv/core/error.h"
#include "fdv/io/recording.h"
#include "fdv/io/recording_summary.h"

namespace fdv::fuzz {

/// The name the targets give their input; errors must carry it.
inline constexpr const char* kInputName = "fuzz-input";

[[noreturn]] inline void contract_broken(const char* what, const std::string& message) {
  std::fprintf(stderr, "contract broken: %s: %s\n", what, message.c_str());
  std::abort();
}

/// Runs `parse`; returns on success or on an error that keeps the contract.
template <class Parse>
void expect_contract(Parse&& parse) {
  try {
    parse();
  } catch (const InputError& e) {
    if (e.file().find(kInputName) == std::string::npos) contract_broken("InputError names another file", e.what());
    if (e.reason().empty()) contract_broken("InputError gives no reason", e.what());
  } catch (const ConfigError& e) {
    if (std::string(e.what()).find(kInputName) == std::string::npos)
      contract_broken("ConfigError does not name the file", e.what());
  }
}

/// Reads a recording to its end as `fdv info` does, and prints nothing: the summary must be JSON
/// that dumps (valid UTF-8).
inline void drain(RecordingReader& reader) { (void)summarize_recording(reader).dump(); }

}  // namespace fdv::fuzz
