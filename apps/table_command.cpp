// `fdv table1` and `fdv table2`: the paper's Table I (ego-motion compensation, plus detection
// metrics) and Table II (trajectory estimation) reproduced on simulated datasets, printed as
// Markdown and optionally written into their own block of a results document (docs/RESULTS.md)
// with the command, seeds, date and commit. The work is fdv::compute_table1/2 (src/fdv/eval).
#include <fmt/chrono.h>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <memory>

#include "apps/commands.h"
#include "fdv/tables/experiment.h"
#include "fdv/tables/markdown_block.h"
#include "fdv/tables/paper_tables.h"

namespace fdv::cli {
namespace {

struct TableArgs {
  std::string seeds = "101-105";
  std::string cache = "out/cache";
  std::string write;  ///< results document; empty: print only
  /// table1 only: seeds of the any-size detection table, "none"; empty: --seeds
  std::string any_size_seeds;
};

/// stdout of a shell command, or nothing when it cannot run or fails.
std::optional<std::string> command_output(const std::string& command) {
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen(command.c_str(), "r"), pclose);
  if (!pipe) return std::nullopt;
  std::string out;
  std::array<char, 256> buffer{};
  while (std::fgets(buffer.data(), static_cast<int>(buffer.size()), pipe.get()))
    out += buffer.data();
  if (pclose(pipe.release()) != 0) return std::nullopt;
  while (!out.empty() && (out.back() == '\n' || out.back() == '\r')) out.pop_back();
  return out;
}

/// Short commit of the source tree this binary was built from, "-dirty" when tracked or untracked
/// (not ignored) files differ from it, except the results document being written; "unknown"
/// without git or outside a repository.
std::string source_revision(const std::string& results_document) {
  const std::string git = fmt::format("git -C '{}' ", FDV_SOURCE_DIR);
  const auto head = command_output(git + "rev-parse --short HEAD 2>/dev/null");
  if (!head || head->empty()) return "unknown";
  // The document being written is excluded: writing it must not mark the next run dirty.
  std::string status_cmd = git + "status --porcelain 2>/dev/null";
  if (!results_document.empty()) {
    namespace fs = std::filesystem;
    const fs::path rel = fs::weakly_canonical(fs::absolute(results_document))
                             .lexically_relative(fs::weakly_canonical(FDV_SOURCE_DIR));
    if (!rel.empty() && *rel.begin() != "..")  // inside the source tree
      status_cmd =
          git + fmt::format("status --porcelain -- . ':(exclude){}' 2>/dev/null", rel.string());
  }
  const auto status = command_output(status_cmd);
  if (!status) return *head + " (status unknown)";
  return *head + (status->empty() ? "" : "-dirty");
}

std::string today_utc() {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&now, &tm);
  return fmt::format("{:%Y-%m-%d %H:%M} UTC", tm);
}

template <class Table, class Compute>
void run_table(const std::string& name, const TableArgs& args, Compute compute) {
  const auto start = std::chrono::steady_clock::now();
  PaperTableOptions options;
  options.seeds = parse_seed_list(args.seeds);
  options.cache_dir = args.cache;
  if (args.any_size_seeds == "none")
    options.any_size_seeds.emplace();
  else if (!args.any_size_seeds.empty())
    options.any_size_seeds = parse_seed_list(args.any_size_seeds);
  const Table table = compute(options);
  Provenance p;
  p.command = fmt::format("fdv {} --seeds {} --cache {}{}{}", name, args.seeds, args.cache,
                          args.any_size_seeds.empty() ? "" : " --any-size-seeds " + args.any_size_seeds,
                          args.write.empty() ? "" : " --write " + args.write);
  p.date = today_utc();
  p.commit = source_revision(args.write);
  const std::string markdown = to_markdown(table, p);
  std::cout << markdown << std::flush;
  if (!args.write.empty()) {
    write_marked_block(args.write, name, markdown);
    spdlog::info("{} written into {}", name, args.write);
  }
  spdlog::info("{} took {:.0f} s", name,
               std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
}

void add_table_options(CLI::App* cmd, TableArgs& args) {
  cmd->add_option("--seeds", args.seeds, "simulator seeds: A-B, or a list like 1,3,7-9")
      ->capture_default_str();
  cmd->add_option("--cache", args.cache, "folder of simulated datasets, reused between runs")
      ->capture_default_str();
  cmd->add_option("--write", args.write,
                  "results document to update (only this table's marked block)");
}

}  // namespace

void add_table_commands(CLI::App& app) {
  static TableArgs args1, args2;
  auto* t1 = app.add_subcommand(
      "table1", "paper Table I: compensation time, relative contrast, detection metrics");
  add_table_options(t1, args1);
  t1->add_option("--any-size-seeds", args1.any_size_seeds,
                 "seeds of the any-size detection table (default: --seeds), or none");
  t1->callback([] { run_table<Table1>("table1", args1, compute_table1); });
  auto* t2 =
      app.add_subcommand("table2", "paper Table II: APE of fusion vs mono; first-estimate latency");
  add_table_options(t2, args2);
  t2->callback([] { run_table<Table2>("table2", args2, compute_table2); });
}

}  // namespace fdv::cli
