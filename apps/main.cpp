// fdv: the command-line front end. Every sub-command is a thin layer over the library.
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <exception>

#include "apps/commands.h"

int main(int argc, char** argv) {
  CLI::App app{"fast-dynamic-vision: detect and track fast-moving objects with event + depth sensing"};
  app.require_subcommand(1);
  bool verbose = false;
  app.add_flag("-v,--verbose", verbose, "debug logging");
  fdv::cli::add_info_command(app);
  // [command slot: simulate]
  // [command slot: run]
  // [command slot: eval]
  // [command slot: bench]
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
