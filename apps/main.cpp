// fdv: the command-line front end. Every sub-command is a thin layer over the library.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <iostream>

#include "apps/commands.h"

int main(int argc, char** argv) {
  CLI::App app{"fast-dynamic-vision: detect and track fast-moving objects with event + depth sensing"};
  app.set_version_flag("--version", "fdv " FDV_VERSION);
  app.require_subcommand(1);
  // Log to stderr: stdout carries the commands' JSON (info, simulate) for pipes.
  spdlog::set_default_logger(spdlog::stderr_color_mt("fdv"));
  app.add_flag_callback("-v,--verbose", [] { spdlog::set_level(spdlog::level::debug); }, "debug logging")
      ->trigger_on_parse();  // before the sub-command's callback runs
  fdv::cli::add_info_command(app);
  fdv::cli::add_simulate_command(app);
  fdv::cli::add_run_command(app);
  fdv::cli::add_eval_command(app);
  fdv::cli::add_demo_command(app);
  fdv::cli::add_table_commands(app);
  fdv::cli::add_dodge_eval_command(app);
  fdv::cli::add_convert_command(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const fdv::cli::Interrupted& e) {
    spdlog::warn("{}", e.what());
    return 128 + e.signal;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  // Output a pipe or a full disk refused is a failure, not a silent success (`fdv info > /dev/full`).
  std::cout.flush();
  if (!std::cout || std::fflush(stdout) != 0 || std::ferror(stdout)) {
    spdlog::error("cannot write to standard output");
    return 1;
  }
  return 0;
}
