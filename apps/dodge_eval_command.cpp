// `fdv dodge-eval`: the escape rate over many random throws, ours beside the baselines
// (fdv/tables/dodge_eval.h; docs/AVOIDANCE.md). Prints a Markdown table; DIR/dodge_eval.json has
// every throw.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <iostream>
#include <string>
#include <vector>

#include "apps/commands.h"
#include "fdv/eval/statistics.h"
#include "fdv/pipeline/options_yaml.h"
#include "fdv/tables/dodge_eval.h"
#include "fdv/tables/experiment.h"

namespace fdv::cli {
namespace {

struct DodgeEvalArgs {
  std::string seeds;
  std::string out;
  std::string config;
  int jobs = 2;
  bool keep = false;
  bool closed_loop = false;
  std::vector<std::string> baselines;
};

std::string percent(int n, int of) { return of > 0 ? fmt::format("{:.1f} %", 100.0 * n / of) : "-"; }

void print_table(const DodgeEval& e, const std::vector<std::string>& methods, OutcomeSet set,
                 const std::string& title) {
  std::cout << "\n" << title << "\n\n| method | threats escaped | false alarms (non-threats) | near misses manoeuvred | "
               "warning time median [s] | miss error at decision median [m] | re-plans |\n"
               "|---|---|---|---|---|---|---|\n";
  for (const std::string& method : methods) {
    const DodgeTotals t = dodge_totals(e.throws, method, set);
    const Summary w = summarize(t.warning_times_s), m = summarize(t.miss_errors_m);
    std::cout << fmt::format("| {} | {}/{} ({}) | {}/{} ({}) | {}/{} | {} | {} | {} |\n", method, t.escaped, t.threats,
                             percent(t.escaped, t.threats), t.false_alarms, t.non_threats,
                             percent(t.false_alarms, t.non_threats), t.near_miss_maneuvers, t.near_misses,
                             w.count ? fmt::format("{:.3f}", w.median) : "-",
                             m.count ? fmt::format("{:.3f}", m.median) : "-", t.replans);
  }
}

/// What the manoeuvres did to perception, per perception method: in the loop, and open loop (the
/// same windows without the manoeuvre seen) as the reference.
void print_maneuver_perception(const DodgeEval& e, const std::vector<std::string>& methods) {
  std::cout << "\nFrom the first decision to the closest approach (the ball eligible):\n\n"
               "| method | recall, closed loop | recall, open loop | tracks lost, closed loop | tracks lost, open loop | "
               "re-created, closed loop | re-created, open loop |\n"
               "|---|---|---|---|---|---|---|\n";
  auto recall = [](const DodgeTotals& t) {
    return fmt::format("{}/{} ({})", t.found_after_decision, t.eligible_after_decision,
                       t.eligible_after_decision ? fmt::format("{:.1f} %", 100.0 * static_cast<double>(t.found_after_decision) /
                                                                        static_cast<double>(t.eligible_after_decision))
                                                 : "-");
  };
  for (const std::string& method : methods) {
    if (method.starts_with("oracle")) continue;  // no perception
    const DodgeTotals closed = dodge_totals(e.throws, method), open = dodge_totals(e.throws, method, &DodgeThrow::open_loop_outcomes);
    std::cout << fmt::format("| {} | {} | {} | {}/{} | {}/{} | {}/{} | {}/{} |\n", method, recall(closed), recall(open),
                             closed.tracks_lost, closed.tracks_checked, open.tracks_lost, open.tracks_checked,
                             closed.tracks_recreated, closed.tracks_checked, open.tracks_recreated, open.tracks_checked);
  }
}

/// The threats oracle_visible escapes and ours does not: where ours' time went.
void print_lags(const nlohmann::json& lags) {
  if (lags.empty()) return;
  auto cell = [](const nlohmann::json& v) { return v.is_null() ? std::string("-") : fmt::format("{:.3f}", v.get<double>()); };
  std::cout << "\nThreats oracle_visible escapes and ours does not [s]:\n\n"
               "| seed | in view | first detection | first usable estimate | decision | oracle_visible's decision |\n"
               "|---|---|---|---|---|---|\n";
  for (const nlohmann::json& l : lags)
    std::cout << fmt::format("| {} | {} | {} | {} | {} | {} |\n", l["seed"].get<std::uint64_t>(),
                             cell(l["first_in_view_t_s"]), cell(l["first_detection_t_s"]),
                             cell(l["first_usable_estimate_t_s"]), cell(l["decision_t_s"]),
                             cell(l["oracle_visible_decision_t_s"]));
}

}  // namespace

void add_dodge_eval_command(CLI::App& app) {
  auto args = std::make_shared<DodgeEvalArgs>();
  CLI::App* cmd = app.add_subcommand(
      "dodge-eval", "simulate one random throw per seed, decide the dodge, score the escape (ours and baselines)");
  cmd->add_option("--seeds", args->seeds, "seeds of sim's random_throw, e.g. 101-300 or 1,3,10-12")->required();
  cmd->add_option("--out", args->out, "output folder: dodge_eval.json (and throws/ with --keep)")->required();
  cmd->add_option("--jobs", args->jobs, "throws evaluated at once, one core each (default 2)")
      ->check(CLI::Range(1, 64));
  cmd->add_option("--config", args->config, "YAML options of the pipeline (as `fdv run --config`)");
  cmd->add_flag("--keep", args->keep, "keep each throw's dataset and run in DIR/throws/SEED/{dataset,run}");
  cmd->add_flag("--closed-loop", args->closed_loop,
                "also fly every method through the simulator's vehicle model, the scene rendered again as it "
                "manoeuvres (docs/AVOIDANCE.md \"Closed loop\"); the totals are then the closed loop's");
  CLI::Option* baselines =
      cmd->add_option("--baselines", args->baselines,
                      "the baselines evaluated beside ours, comma-separated, or none (default "
                      "point_estimate,mono,rotation); fewer is faster, the oracles always run")
          ->delimiter(',');
  cmd->callback([args, baselines] {
    DodgeEvalOptions o;
    o.seeds = parse_seed_list(args->seeds);
    o.out_dir = args->out;
    o.jobs = args->jobs;
    o.keep = args->keep;
    o.closed_loop = args->closed_loop;
    if (baselines->count() > 0) {
      o.baselines = args->baselines;
      std::erase(o.baselines, "none");
    }
    if (!args->config.empty()) o.perception = load_perception_options_file(args->config);
    spdlog::info("dodge-eval: {} throws, {} at a time, into {}", o.seeds.size(), o.jobs, o.out_dir);
    const DodgeEval e = run_dodge_eval(o);
    const std::vector<std::string> methods = evaluated_methods(o);
    if (o.closed_loop) {
      print_table(e, methods, &DodgeThrow::outcomes, "Closed loop (flown, the scene rendered again):");
      print_maneuver_perception(e, methods);
      print_table(e, methods, &DodgeThrow::dynamics_outcomes,
                  "Open-loop decisions flown by the vehicle model, not rendered again:");
      print_table(e, methods, &DodgeThrow::open_loop_outcomes, "Open loop (kinematic replay):");
    } else {
      print_table(e, methods, &DodgeThrow::outcomes, "Open loop (kinematic replay):");
    }
    const nlohmann::json j = to_json(e, o);
    print_lags(j["late_against_oracle_visible"]);
    std::cout << fmt::format(
        "\n{} throws in {:.0f} s; ours escaped {} of the {} threats the oracle escaped ({}), {} of the {} that "
        "oracle_visible escaped ({}); {}/dodge_eval.json\n",
        e.throws.size(), e.wall_s, j["escaped_where_oracle_escaped"].get<int>(), j["oracle_escaped"].get<int>(),
        percent(j["escaped_where_oracle_escaped"].get<int>(), j["oracle_escaped"].get<int>()),
        j["escaped_where_oracle_visible_escaped"].get<int>(), j["oracle_visible_escaped"].get<int>(),
        percent(j["escaped_where_oracle_visible_escaped"].get<int>(), j["oracle_visible_escaped"].get<int>()), o.out_dir);
  });
}

}  // namespace fdv::cli
