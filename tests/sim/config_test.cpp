// Scenario configuration: presets, YAML overrides, and clear errors for bad values.
#include <gtest/gtest.h>

#include <fstream>

#include "fdv/core/config_text.h"
#include "fdv/core/error.h"
#include "fdv/sim/scenario_config.h"
#include "test_support.h"

namespace fdv::sim {
namespace {

std::string write_config(const std::string& name, const std::string& text) {
  const std::string path = fdv::test::scratch_dir("sim_config") + "/" + name;
  std::ofstream(path) << text;
  return path;
}

TEST(ScenarioConfig, EveryPresetIsValidAndDiffersBySeed) {
  for (const auto& name : preset_names()) {
    const ScenarioConfig a = make_preset(name, 1), b = make_preset(name, 2);
    EXPECT_EQ(a.validate(), "") << name;
    EXPECT_EQ(a.name, name);
    EXPECT_NE(to_yaml(a), to_yaml(b)) << name << ": the seed must change the scene";
    EXPECT_EQ(to_yaml(a), to_yaml(make_preset(name, 1))) << name << ": presets are deterministic";
  }
  EXPECT_THROW(make_preset("no_such_scene", 1), ConfigError);
  try {
    make_preset("no_such_scene", 1);
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("fast_forward"), std::string::npos)
        << "lists the known names";
  }
}

TEST(ScenarioConfig, PresetsMatchTheIssue) {
  const auto s1 = make_preset("scene1_no_object", 1);
  EXPECT_GT(s1.vehicle.speed_m_s, 5.0);
  EXPECT_TRUE(s1.balls.empty());
  const auto s2 = make_preset("scene2_ball", 1);
  ASSERT_EQ(s2.balls.size(), 1u);
  EXPECT_GT(s2.balls[0].speed_m_s, 10.0);
  const auto ff = make_preset("fast_forward", 1);
  EXPECT_DOUBLE_EQ(ff.vehicle.speed_m_s, 2.0);
  EXPECT_NEAR(ff.balls[0].speed_m_s, 12.0, 1.0);
  EXPECT_EQ(make_preset("swing", 1).vehicle.motion, MotionKind::kSwing);
  const auto ho = make_preset("hover_headon", 1);
  EXPECT_EQ(ho.vehicle.motion, MotionKind::kHover);
  EXPECT_DOUBLE_EQ(ho.balls[0].radius_m, 0.105);
  const double distance = ho.balls[0].from_m.norm();
  EXPECT_GE(distance, 8.0 - 0.6);  // 8-10 m ahead, with a thrower's height offset
  EXPECT_LE(distance, 10.0 + 0.6);
  EXPECT_GE(ho.balls[0].speed_m_s, 7.0);
  EXPECT_LE(ho.balls[0].speed_m_s, 12.0);
  EXPECT_LT(make_preset("dim", 1).scene.illuminance_lux, ho.scene.illuminance_lux / 10);
}

TEST(ScenarioConfig, YamlOverridesOnlyTheGivenFields) {
  ScenarioConfig c = make_preset("fast_forward", 3);
  const ScenarioConfig before = c;
  const std::string path = write_config("override.yaml",
                                      "duration_s: 0.25\n"
                                      "event_camera:\n  contrast_threshold_mean: 0.3\n"
                                      "vehicle:\n  motion: swing\n"
                                      "balls:\n  - speed_m_s: 9.5\n");
  apply_scenario_yaml(c, path);
  EXPECT_DOUBLE_EQ(c.duration_s, 0.25);
  EXPECT_DOUBLE_EQ(c.event_camera.contrast_threshold_mean, 0.3);
  EXPECT_EQ(c.vehicle.motion, MotionKind::kSwing);
  ASSERT_EQ(c.balls.size(), 1u);
  EXPECT_DOUBLE_EQ(c.balls[0].speed_m_s, 9.5);
  // Untouched: the rest of the ball (starts from the preset's element), other sections.
  EXPECT_EQ(c.balls[0].from_m, before.balls[0].from_m);
  EXPECT_DOUBLE_EQ(c.balls[0].radius_m, 0.105);
  EXPECT_DOUBLE_EQ(c.event_camera.contrast_threshold_spread,
                   before.event_camera.contrast_threshold_spread);
  EXPECT_EQ(c.scene.panels.size(), before.scene.panels.size());
}

TEST(ScenarioConfig, YamlRoundTripsEveryField) {
  const ScenarioConfig a = make_preset("swing", 5);
  ScenarioConfig b;  // defaults, then everything from a's dump
  apply_scenario_yaml(b, YAML::Load(to_yaml(a)), "dump");
  EXPECT_EQ(to_yaml(b), to_yaml(a));
}

std::string error_of(const std::string& yaml) {
  ScenarioConfig c = make_preset("fast_forward", 1);
  const std::string path = write_config("bad.yaml", yaml);
  return test::input_error_of(path, [&] { apply_scenario_yaml(c, path); });
}

TEST(ScenarioConfig, BadFilesGiveFileKeyAndReason) {
  EXPECT_EQ(error_of("event_camera:\n  contrast_treshold_mean: 0.2\n").substr(0, 45),
            "key event_camera.contrast_treshold_mean | unk");
  EXPECT_EQ(error_of("duration_s: abc\n"), "key duration_s | 'abc' is not a number");
  EXPECT_EQ(error_of("event_camera:\n  refractory_s: -1\n"),
            "key event_camera.refractory_s | must be in [0, 0.1], got -1");
  EXPECT_EQ(error_of("event_camera:\n  width: 12.5\n"),
            "key event_camera.width | '12.5' is not an integer");
  EXPECT_EQ(error_of("vehicle:\n  motion: teleport\n"),
            "key vehicle.motion | 'teleport' is not one of hover, forward, swing, constant");
  EXPECT_EQ(error_of("balls:\n  - radius_m: 0\n"),
            "key balls[0].radius_m | must be in [0.001, 5], got 0");
  EXPECT_EQ(error_of("scene:\n  room_min_W_m: [1, 2]\n"),
            "key scene.room_min_W_m | expected a list of 3 numbers");
  EXPECT_EQ(error_of("imu: 5\n"), "key imu | expected a mapping of keys");
  EXPECT_EQ(error_of("event_camera: {width: 640\n").substr(0, 8), "line 2, ");
  EXPECT_EQ(error_of("depth_camera:\n  min_range_m: 12\n"),
            "key depth_camera.max_range_m | must exceed min_range_m");
  EXPECT_EQ(error_of("vehicle:\n  response: {min_height_m: 2, max_height_m: 1.5}\n"),
            "key vehicle.response.max_height_m | must be a number above min_height_m (2), got 1.5");
  EXPECT_EQ(error_of("scene:\n  room_max_W_m: [60, 5, 3]\n"),
            "key vehicle.response.max_height_m | must not be above the room's ceiling "
            "(scene.room_max_W_m z = 3), got 4.5");
  EXPECT_EQ(error_of("vehicle:\n  response: {wall_margin_m: 5}\n"),
            "key vehicle.response.wall_margin_m | must leave the walls apart: twice it below the "
            "room's narrowest side in x and y (10 m), got 5");
}

/// "where | reason" of apply_scenario_yaml_text on `yaml` (named "scenario.yaml").
std::string text_error_of(const std::string& yaml) {
  ScenarioConfig c = make_preset("fast_forward", 1);
  return test::input_error_of("scenario.yaml", [&] { apply_scenario_yaml_text(c, yaml, "scenario.yaml"); });
}

TEST(ScenarioConfig, MalformedStructureNamesFileAndKey) {
  EXPECT_EQ(text_error_of("duration_s: 2.5\n"), "no error");
  EXPECT_EQ(text_error_of("[a, b]: 1\n"), "key ? | a key must be a plain name, not a list or map (line 1)");
  EXPECT_EQ(text_error_of("event_camera:\n  {x: 1}: 2\n"),
            "key event_camera.? | a key must be a plain name, not a list or map (line 2)");
  EXPECT_EQ(text_error_of("balls:\n  - [1]: 2\n"),
            "key balls[0].? | a key must be a plain name, not a list or map (line 2)");
  EXPECT_EQ(text_error_of("42\n"), " | a scenario file must be a mapping of keys");
  EXPECT_EQ(text_error_of("- a\n"), " | a scenario file must be a mapping of keys");
  EXPECT_EQ(text_error_of("balls: {a: 1}\n"), "key balls | expected a list");
  EXPECT_EQ(text_error_of("balls: [5]\n"), "key balls[0] | expected a mapping of keys");
  std::string many = "balls: [";
  for (int i = 0; i < 100000; ++i) many += "{},";
  EXPECT_EQ(text_error_of(many + "]\n"), "key balls | 100000 items, at most 64 are read");
  EXPECT_EQ(text_error_of("name: [a]\n"), "key name | expected a string");
  EXPECT_EQ(text_error_of("seed: {a: 1}\n"), "key seed | expected a non-negative integer");
  EXPECT_EQ(text_error_of("scene: {panels: [{albedo: [1]}]}\n"),
            "key scene.panels[0].albedo | expected a number");
  EXPECT_NE(text_error_of("scene: " + std::string(60000, '[')).find("| nested deeper than"),
            std::string::npos);
  EXPECT_EQ(text_error_of(std::string(kMaxConfigFileBytes + 1, '#')),
            " | larger than 1048576 bytes: not a configuration file");
}

TEST(ScenarioConfig, LoadScenarioYamlChecksSizeAndSyntax) {
  const std::string path = write_config("s.yaml", "name: swing\nseed: 3\n");
  EXPECT_EQ(load_scenario_yaml(path)["name"].Scalar(), "swing");
  const std::string bad = write_config("bad.yaml", "name: [swing\n");
  try {
    load_scenario_yaml(bad);
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), bad);
    EXPECT_EQ(e.where().substr(0, 7), "line 2,");
  }
  EXPECT_THROW(load_scenario_yaml(write_config("none/../missing.yaml", "")), InputError);
}

TEST(ScenarioConfig, ValidateNamesTheKey) {
  ScenarioConfig c;
  c.event_camera.background_on_fraction = 1.5;
  EXPECT_EQ(c.validate(), "event_camera.background_on_fraction: must be in [0, 1], got 1.5");
  c = ScenarioConfig{};
  c.event_camera.distortion = {-0.9, 0, 0, 0, 0};  // folds back inside the image
  EXPECT_EQ(c.validate().substr(0, 24), "event_camera.distortion:");
  c = ScenarioConfig{};
  c.balls.resize(2);
  EXPECT_EQ(c.validate(), "balls[1].id: id 1 used twice");
}

TEST(ScenarioConfig, ResolutionChangeKeepsTheFieldOfView) {
  ScenarioConfig c;
  set_event_resolution(c, 320, 240);
  EXPECT_DOUBLE_EQ(c.event_camera.fx, 536.3 / 2);
  // The left edge of the image (u = -0.5) stays at the same normalised coordinate.
  EXPECT_NEAR((-0.5 - c.event_camera.cx) / c.event_camera.fx, (-0.5 - 320.9) / 536.3, 1e-12);
  EXPECT_THROW(set_event_resolution(c, 0, 10), ConfigError);
}

}  // namespace
}  // namespace fdv::sim
