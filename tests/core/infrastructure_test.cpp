// The small shared helpers of core: thread pool, lanes, numeric checks, yaml-cpp errors.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "fdv/core/config_text.h"
#include "fdv/core/lanes.h"
#include "fdv/core/numeric.h"
#include "fdv/core/thread_pool.h"
#include "test_support.h"

namespace fdv {
namespace {

TEST(ThreadPool, RunsEveryIndexOnce) {
  for (const int threads : {1, 2, 3}) {
    ThreadPool pool(threads);
    EXPECT_EQ(pool.size(), threads);
    std::vector<std::atomic<int>> hits(1000);
    pool.parallel_for(hits.size(), [&](std::size_t i) { ++hits[i]; });
    for (const auto& h : hits) EXPECT_EQ(h.load(), 1);
  }
}

TEST(ThreadPool, RethrowsAnExceptionAfterTheLoop) {
  ThreadPool pool(2);
  std::atomic<int> done{0};
  EXPECT_THROW(pool.parallel_for(100,
                                 [&](std::size_t i) {
                                   ++done;
                                   if (i == 7) throw std::runtime_error("item 7");
                                 }),
               std::runtime_error);
  EXPECT_EQ(done.load(), 100);
  // Usable again afterwards.
  std::atomic<int> n{0};
  pool.parallel_for(10, [&](std::size_t) { ++n; });
  EXPECT_EQ(n.load(), 10);
}

TEST(ThreadPool, ANestedCallRunsOnTheCallingThread) {
  ThreadPool pool(2);
  std::vector<std::atomic<int>> hits(16);
  pool.parallel_for(
      4, [&](std::size_t i) { pool.parallel_for(4, [&](std::size_t j) { ++hits[4 * i + j]; }); });
  for (const auto& h : hits) EXPECT_EQ(h.load(), 1);
}

TEST(RunParts, EveryPartOnceOnTheSharedPool) {
  for (const int parts : {1, 2, 5, 64}) {
    std::vector<int> hits(static_cast<std::size_t>(parts), 0);  // each part writes its own slot
    run_parts(parts, [&](int i) { ++hits[static_cast<std::size_t>(i)]; });
    for (const int h : hits) EXPECT_EQ(h, 1);
  }
}

TEST(Lanes, SelectMinMaxAbsFloor) {
  using namespace lanes;
  const float xs[4] = {-1.5f, 2.0f, -0.0f, 3.25f};
  const vf x = load(xs);
  const vf a = abs(x), lo = min(x, splat(0.0f)), hi = max(x, splat(0.0f));
  const vi f = floor_i(x);
  const int floors[4] = {-2, 2, 0, 3};
  for (int k = 0; k < kLanes; ++k) {
    EXPECT_EQ(a[k], std::abs(xs[k]));
    EXPECT_EQ(lo[k], xs[k] < 0.0f ? xs[k] : 0.0f);
    EXPECT_EQ(hi[k], xs[k] > 0.0f ? xs[k] : 0.0f);
    EXPECT_EQ(f[k], floors[k]);
  }
  float out[4];
  store(out, select(x < 0, splat(1.0f), splat(2.0f)));
  EXPECT_EQ(out[0], 1.0f);
  EXPECT_EQ(out[1], 2.0f);
  EXPECT_TRUE(any(x < 0));
  EXPECT_FALSE(any(x > 10));
  EXPECT_TRUE(all_equal(splat_i(7)));
  EXPECT_FALSE(all_equal(f));
}

TEST(Numeric, PositiveFinite) {
  EXPECT_TRUE(positive_finite(1e-300));
  EXPECT_FALSE(positive_finite(0.0));
  EXPECT_FALSE(positive_finite(-1.0));
  EXPECT_FALSE(positive_finite(std::numeric_limits<double>::infinity()));
  EXPECT_FALSE(positive_finite(std::numeric_limits<double>::quiet_NaN()));
}

TEST(ConfigText, YamlErrorsBecomeInputErrorsNamingTheFile) {
  const YAML::Node root = parse_config_yaml("a: [1, 2]\n", "opts.yaml");
  EXPECT_EQ(yaml_errors_as_input_errors("opts.yaml", [&] { return root["a"][1].as<int>(); }), 2);
  try {
    yaml_errors_as_input_errors("opts.yaml", [&] { (void)root["a"].as<int>(); });
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("opts.yaml"), std::string::npos) << e.what();
  }
}

TEST(ConfigText, ARepeatedKeyIsAnErrorButTheSameKeyInTwoMappingsIsNot) {
  EXPECT_EQ(test::input_error_of("f.yaml", [] { parse_config_yaml("a:\n  - {k: 1, k: 2}\n", "f.yaml"); }),
            "line 2, column 12 | duplicate key 'k' (first at line 2, column 6)");
  // A mapping reached again through an alias is the same mapping, walked once.
  EXPECT_NO_THROW(parse_config_yaml("a: &x {k: 1}\nb: *x\nc: {k: 2}\n", "f.yaml"));
  // Aliases nested 30 deep stand for 2^30 mappings: the walk visits each written one once.
  std::string text = "l0: &l0 {k: 1}\n";
  for (int i = 1; i <= 30; ++i)
    text += "l" + std::to_string(i) + ": &l" + std::to_string(i) + " [*l" + std::to_string(i - 1) + ", *l" +
            std::to_string(i - 1) + "]\n";
  EXPECT_NO_THROW(parse_config_yaml(text, "f.yaml"));
}

}  // namespace
}  // namespace fdv
