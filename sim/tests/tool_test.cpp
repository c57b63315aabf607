// rsrio-sim end to end: the recording it writes holds what the library makes, in log-time order,
// with the right stamps and frames; bad input gives exit code 2 and names the problem.
#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <catch2/catch_test_macros.hpp>

#include "rsrio/driver/adc_layout.hpp"
#include "rsrio/recording/recording.hpp"
#include "rsrio/sim/scenario.hpp"
#include "rsrio/sim/simulation.hpp"
#include "scratch_dir.hpp"

namespace fs = std::filesystem;

namespace {

struct Run {
  int exit_code = -1;
  std::string err;
};

fs::path temp(const std::string& name) {
  static const rsrio::testing::ScratchDir dir("sim_tool_test");
  return dir.path() / name;
}

Run run(const std::string& args) {
  static int calls = 0;
  const fs::path err = temp("run" + std::to_string(++calls) + ".err");
  const std::string cmd = std::string(RSRIO_SIM_EXE) + " " + args + " 2>" + err.string() + " >/dev/null";
  const int status = std::system(cmd.c_str());
  Run r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ostringstream s;
  s << std::ifstream(err).rdbuf();
  r.err = s.str();
  fs::remove(err);
  return r;
}

std::uint64_t stamp_ns(const builtin_interfaces::msg::Time& t) {
  return static_cast<std::uint64_t>(t.sec()) * 1'000'000'000ull + t.nanosec();
}

}  // namespace

TEST_CASE("sim: rsrio-sim writes radar, IMU and ground truth in order", "[tool]") {
  const fs::path out = temp("out.mcap");
  const Run r = run("--scenario scenarios/test_tiny.yaml --out " + out.string() + " --seconds 1.0 --threads 2");
  INFO(r.err);
  REQUIRE(r.exit_code == 0);

  const rsrio::sim::Scenario scenario = rsrio::sim::load_scenario("scenarios/test_tiny.yaml");
  rsrio::sim::Simulation sim(scenario, 1);
  const std::uint64_t frames = sim.radar().frames_until(1.0);
  REQUIRE(frames >= 8);
  const std::uint64_t epoch = static_cast<std::uint64_t>(std::llround(scenario.start_time_unix_s * 1e9));

  rsrio::RecordingReader reader(out.string());
  CHECK(reader.profile() == "ros2");
  rsrio::RecordedMessage m;
  std::uint64_t n_radar = 0, n_imu = 0, n_gt = 0, last_log = 0;
  while (reader.next(m)) {
    CHECK(m.log_time_ns >= last_log);
    last_log = m.log_time_ns;
    if (m.topic == rsrio::topics::kRadarRaw) {
      rsrio_msgs::msg::RadarFrame f;
      REQUIRE(rsrio::decode(m, f));
      CHECK(f.frame_number() == n_radar);
      CHECK((f.flags() & rsrio_msgs::msg::RadarFrame_Constants::FLAG_SIMULATED) != 0);
      CHECK(f.header().frame_id() == "radar");
      const double done = sim.radar().frame_completion(n_radar);
      CHECK(std::llabs(static_cast<long long>(stamp_ns(f.header().stamp()) - epoch) - std::llround(done * 1e9)) <= 1);
      const rsrio::RadarConfig config = rsrio::from_msg(f.config());
      CHECK(config.loops == 16);
      REQUIRE(f.adc().size() == rsrio::raw_frame_bytes(config));
      if (n_radar == 2) {
        // The same bytes as the library makes in this process.
        rsrio::AdcCube cube;
        sim.radar().simulate(2, cube);
        std::vector<std::uint8_t> bytes;
        rsrio::encode_frame(sim.radar().config(), cube, bytes);
        CHECK(bytes == f.adc());
      }
      ++n_radar;
    } else if (m.topic == rsrio::topics::kImu) {
      sensor_msgs::msg::Imu imu;
      REQUIRE(rsrio::decode(m, imu));
      CHECK(imu.header().frame_id() == "imu");
      // Stamped by the IMU's clock: true time + offset; logged at the true time.
      const long long offset = static_cast<long long>(stamp_ns(imu.header().stamp())) - static_cast<long long>(m.log_time_ns);
      CHECK(std::llabs(offset - 4'000'000) <= 1);
      CHECK(std::abs(imu.linear_acceleration().z() - 9.81) < 2.0);
      ++n_imu;
    } else if (m.topic == rsrio::topics::kGroundTruth) {
      nav_msgs::msg::Odometry gt;
      REQUIRE(rsrio::decode(m, gt));
      CHECK(gt.header().frame_id() == "map");
      CHECK(gt.child_frame_id() == "radar");
      const double t = static_cast<double>(stamp_ns(gt.header().stamp()) - epoch) * 1e-9;
      const rsrio::sim::RigState truth = sim.radar_state(t);
      CHECK(std::abs(gt.pose().pose().position().x() - truth.position.x()) < 1e-6);
      const Eigen::Vector3d v_radar = truth.rotation.transpose() * truth.velocity;
      CHECK(std::abs(gt.twist().twist().linear().x() - v_radar.x()) < 1e-6);
      ++n_gt;
    }
  }
  CHECK(!reader.damage().has_value());
  CHECK(n_radar == frames);
  CHECK(n_imu == 201);  // 0 .. 1 s at 200 Hz
  CHECK(n_gt == n_imu);
  fs::remove(out);
}

TEST_CASE("sim: rsrio-sim --rosbag2 makes a bag directory", "[tool]") {
  const fs::path dir = temp("bag");
  fs::remove_all(dir);
  fs::create_directories(dir);
  const Run r = run("--scenario scenarios/test_tiny.yaml --out " + (dir / "tiny_0.mcap").string() +
                    " --seconds 0.5 --rosbag2");
  INFO(r.err);
  CHECK(r.exit_code == 0);
  CHECK(fs::exists(dir / "metadata.yaml"));
  fs::remove_all(dir);
}

TEST_CASE("sim: rsrio-sim refuses bad input with exit code 2", "[tool]") {
  const std::string out = temp("bad.mcap").string();
  Run r = run("--scenario scenarios/no_such_file.yaml --out " + out);
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("no_such_file.yaml") != std::string::npos);

  const fs::path bad = temp("bad.yaml");
  std::ofstream(bad) << "radar: {preset: mmwcas}\ntrajectory: {waypoints: [0, 0, 3, 0], sped_mps: 1}\n";
  r = run("--scenario " + bad.string() + " --out " + out);
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("trajectory.sped_mps") != std::string::npos);

  r = run("--scenario scenarios/test_tiny.yaml --out " + out + " --seconds soon");
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("--seconds") != std::string::npos);
  r = run("--scenario scenarios/test_tiny.yaml --out " + out + " --radar awr9999");
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("mmwcas") != std::string::npos);
  r = run("--out " + out);
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("--scenario") != std::string::npos);
  CHECK(run("--help").exit_code == 0);
  CHECK(run("--version").exit_code == 0);
  fs::remove(bad);
  fs::remove(out);
}
