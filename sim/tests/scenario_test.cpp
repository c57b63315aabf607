// The shipped scenarios against the paper's Table I, and the scenario loader's strictness.
#include <cmath>
#include <filesystem>
#include <map>
#include <numbers>
#include <string>

#include <catch2/catch_test_macros.hpp>

#include "rsrio/common/options.hpp"
#include "rsrio/sim/scenario.hpp"
#include "scratch_dir.hpp"

using namespace rsrio::sim;
namespace fs = std::filesystem;

namespace {

// RadarSplat-RIO, Table I: distance (m) and duration (s) of the five sequences.
struct Sequence {
  double length_m, duration_s;
};
const std::map<std::string, Sequence> kTableI = {
    {"seq1_meeting_room", {42.46, 141.07}},     {"seq2_small_loop", {91.89, 157.98}},
    {"seq3_large_loop", {144.59, 232.74}},      {"seq4_small_large_loop", {206.12, 263.19}},
    {"seq5_medium_large_loop", {233.54, 320.06}}};

// Tests run from the repository root (rsrio_add_test sets the working directory).
const fs::path kScenarios = "scenarios";

fs::path write_temp(const std::string& name, const std::string& text) {
  static const rsrio::testing::ScratchDir dir("sim_scenario_test");
  return dir.write(name + ".yaml", text);
}

std::string error_of(const std::string& name, const std::string& text) {
  const fs::path file = write_temp(name, text);
  std::string result = "no error";
  try {
    load_scenario(file.string());
  } catch (const rsrio::ConfigError& e) {
    result = e.key() + " | " + e.what();
  }
  fs::remove(file);
  return result;
}

const char* kMinimal = R"(radar:
  preset: xwr1843
trajectory:
  waypoints: [0, 0, 3, 0]
)";

}  // namespace

TEST_CASE("sim: the five sequences match the paper's Table I and close their loops", "[scenario]") {
  for (const auto& [name, expected] : kTableI) {
    INFO(name);
    const Scenario s = load_scenario((kScenarios / (name + ".yaml")).string());
    CHECK(s.name == name);
    const SplineTrajectory t(s.trajectory);
    const double length = t.length(), duration = s.effective_duration(t);
    INFO("length " << length << " m, duration " << duration << " s");
    CHECK(std::abs(length / expected.length_m - 1) < 0.05);
    CHECK(std::abs(duration / expected.duration_s - 1) < 0.05);
    // The mmwcas cascade at 10 Hz, as the paper's rig.
    CHECK(s.radar.preset == "mmwcas");
    CHECK(s.radar.frame_period_ms == 100.0);
    // A loop: once the walker has been more than 5 m away, it comes back within 1.5 m of the start.
    const Eigen::Vector2d start = t.state(0).position.head<2>();
    bool left = false, returned = false;
    double max_acc = 0, max_yaw_rate = 0;
    for (double time = 0; time <= t.duration(); time += 0.05) {
      const RigState st = t.state(time);
      const double d = (st.position.head<2>() - start).norm();
      left = left || d > 5.0;
      returned = returned || (left && d < 1.5);
      max_acc = std::max(max_acc, st.acceleration.norm());
      max_yaw_rate = std::max(max_yaw_rate, std::abs(st.angular_velocity.z()));
    }
    CHECK(returned);
    CHECK(max_acc < 2.5);
    CHECK(max_yaw_rate < 90 * std::numbers::pi / 180);
    // An indoor scene with walls, furniture, pillars and people.
    CHECK(s.scene.walls.size() >= 2);
    CHECK(!s.scene.boxes.empty());
    CHECK(!s.scene.pillars.empty());
    CHECK(!s.scene.people.empty());
  }
}

TEST_CASE("sim: every shipped scenario file loads", "[scenario]") {
  int files = 0;
  for (const auto& entry : fs::directory_iterator(kScenarios)) {
    if (entry.path().extension() != ".yaml") continue;
    INFO(entry.path());
    CHECK_NOTHROW(load_scenario(entry.path().string()));
    ++files;
  }
  CHECK(files >= 6);
}

TEST_CASE("sim: a bad scenario is refused with the key named", "[scenario]") {
  CHECK(error_of("ok", kMinimal) == "no error");
  CHECK(error_of("unknown_top", std::string(kMinimal) + "sead: 3\n").rfind("sead |", 0) == 0);
  CHECK(error_of("odd_waypoints", "radar: {preset: mmwcas}\ntrajectory: {waypoints: [0, 0, 3]}\n")
            .rfind("trajectory.waypoints |", 0) == 0);
  CHECK(error_of("no_trajectory", "radar: {preset: mmwcas}\n").rfind("trajectory |", 0) == 0);
  CHECK(error_of("bad_preset", "radar: {preset: awr9999}\ntrajectory: {waypoints: [0, 0, 3, 0]}\n")
            .rfind("radar.preset |", 0) == 0);
  CHECK(error_of("wall_typo", std::string(kMinimal) + "scene:\n  walls:\n    north: {points: [0, 0, 1, 0], hight_m: 2}\n")
            .rfind("scene.walls.north.hight_m |", 0) == 0);
  CHECK(error_of("box_size", std::string(kMinimal) + "scene:\n  boxes:\n    desk: {center: [1, 1], size_m: [1, 1]}\n")
            .rfind("scene.boxes.desk.size_m |", 0) == 0);
  CHECK(error_of("speed", std::string(kMinimal).substr(0, std::string(kMinimal).size() - 1) + "\n  speed_mps: -1\n")
            .rfind("trajectory.speed_mps |", 0) == 0);
  CHECK(error_of("pauses", "radar: {preset: mmwcas}\ntrajectory: {waypoints: [0, 0, 3, 0], pauses_s: [1]}\n")
            .rfind("trajectory.pauses_s |", 0) == 0);
  CHECK(error_of("person", std::string(kMinimal) + "scene:\n  people:\n    bob: {path: [1, 1], speed_mps: 1}\n")
            .rfind("scene.people.bob.path |", 0) == 0);
  CHECK(error_of("imu_rate", std::string(kMinimal) + "imu: {rate_hz: 0}\n").rfind("imu.rate_hz |", 0) == 0);
}

TEST_CASE("sim: scenario keys land in the model", "[scenario]") {
  const Scenario s = load_scenario((kScenarios / "test_tiny.yaml").string());
  CHECK(s.seed == 7);
  CHECK(s.radar.preset == "xwr1843");
  CHECK(s.radar.loops == 16);
  CHECK(s.trajectory.waypoints.size() == 3);
  CHECK(s.trajectory.height_m == 1.0);
  CHECK(std::abs(s.rig.imu_time_offset_s - 0.004) < 1e-15);
  CHECK((s.rig.radar_in_imu.translation - Eigen::Vector3d(0.03, 0, -0.07)).norm() < 1e-15);
  REQUIRE(s.scene.walls.size() == 2);
  CHECK(s.scene.walls[0].name == "room");
  CHECK(s.scene.walls[0].spacing_m == 0.3);  // from wall_defaults
  CHECK(s.scene.walls[1].mirror_loss_db == 6.0);
  CHECK(s.scene.people.at(0).start_s == 0.5);
}
