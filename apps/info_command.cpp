// `fdv info INPUT`: a JSON summary of any supported recording.
#include <iostream>

#include "apps/commands.h"
#include "apps/reader_flags.h"
#include "fdv/io/recording_summary.h"

namespace fdv::cli {

void add_info_command(CLI::App& app) {
  auto* cmd = app.add_subcommand("info", "print a JSON summary of a recording (any supported format)");
  static std::string input;
  static ReaderOptions options;
  cmd->add_option("input", input, "recording file or dataset folder")->required();
  add_reader_flags(cmd, options);
  // Bytes of a path that are not UTF-8 print as U+FFFD, as in summary.json (results/writer.cpp).
  cmd->callback([] {
    std::cout << summarize_recording(*open_recording(input, options))
                     .dump(2, ' ', false, nlohmann::json::error_handler_t::replace)
              << std::endl;
  });
}

}  // namespace fdv::cli
