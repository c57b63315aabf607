#include "rsrio/sim/scenario.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <sstream>

#include <opencv2/core.hpp>
#include <opencv2/core/utils/logger.hpp>

#include "rsrio/common/options.hpp"

namespace rsrio::sim {

namespace {

constexpr double kDeg = std::numbers::pi / 180;

// The names of a map's keys, in file order. OptionsNode reads keys it is told; the named objects
// of a scene (walls, boxes, ...) are keys nobody knows in advance, so their names come from a
// second, raw look at the same file.
class KeyLister {
 public:
  explicit KeyLister(const std::string& path) {
    std::ostringstream buffer;
    buffer << std::ifstream(path, std::ios::binary).rdbuf();
    std::string text = buffer.str();
    const auto first = text.find_first_not_of(" \t\r\n");
    if (first != std::string::npos && text[first] != '%') text = "%YAML:1.0\n---\n" + text;
    const auto previous = cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
    try {
      storage_.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
    } catch (const cv::Exception&) {
      // OptionsFile has already accepted this file; nothing to list then.
    }
    cv::utils::logging::setLogLevel(previous);
  }
  std::vector<std::string> keys(const std::vector<std::string>& path) const {
    if (!storage_.isOpened()) return {};
    cv::FileNode n = storage_.root();
    for (const auto& p : path) {
      if (!n.isMap()) return {};
      n = n[p];
    }
    if (!n.isMap()) return {};
    std::vector<std::string> out;
    for (const auto& k : n.keys()) out.push_back(k);
    return out;
  }

 private:
  cv::FileStorage storage_;
};

void read_vector2(OptionsNode& node, std::string_view key, Eigen::Vector2d& out) {
  if (!node.has(key)) return;
  std::vector<double> v;
  node.read(key, v);
  if (v.size() != 2) node.fail(key, "[x, y] (two numbers, m)");
  out = Eigen::Vector2d(v[0], v[1]);
}

void read_vector3(OptionsNode& node, std::string_view key, Eigen::Vector3d& out, const std::string& what) {
  if (!node.has(key)) return;
  std::vector<double> v;
  node.read(key, v);
  if (v.size() != 3) node.fail(key, what + " (three numbers)");
  out = Eigen::Vector3d(v[0], v[1], v[2]);
}

// A polyline as a flat list x0, y0, x1, y1, ...
void read_points(OptionsNode& node, std::string_view key, std::vector<Eigen::Vector2d>& out, std::size_t min_points,
                 bool required) {
  if (!node.has(key)) {
    if (required) node.fail(key, "a flat list of points x0, y0, x1, y1, ... in m (the key is required)");
    return;
  }
  std::vector<double> v;
  node.read(key, v);
  if (v.size() % 2 != 0) node.fail(key, "a flat list of points x0, y0, x1, y1, ... (an even count of numbers), got " +
                                            std::to_string(v.size()) + " numbers");
  if (v.size() / 2 < min_points)
    node.fail(key, "at least " + std::to_string(min_points) + " points, got " + std::to_string(v.size() / 2));
  out.clear();
  for (std::size_t i = 0; i < v.size(); i += 2) out.emplace_back(v[i], v[i + 1]);
  for (std::size_t i = 1; i < out.size(); ++i)
    if ((out[i] - out[i - 1]).norm() < 1e-6)
      node.fail(key, "distinct consecutive points, points " + std::to_string(i - 1) + " and " + std::to_string(i) +
                         " coincide");
}

void read_wall_keys(OptionsNode& n, WallOptions& w) {
  n.read("height_m", w.height_m, {0.05, 100.0});
  n.read("spacing_m", w.spacing_m, {0.01, 10.0});
  n.read("row_spacing_m", w.row_spacing_m, {0.01, 10.0});
  n.read("rcs_m2", w.rcs_m2, {0.0, 1e4});
  n.read("jitter_m", w.jitter_m, {0.0, 1.0});
  n.read("incidence_exponent", w.incidence_exponent, {0.0, 100.0});
}

void read_scene(OptionsNode node, const KeyLister& lister, SceneOptions& scene) {
  int seed = static_cast<int>(scene.seed);
  node.read("seed", seed, {0, std::numeric_limits<int>::max()});
  scene.seed = static_cast<std::uint64_t>(seed);
  node.read("multipath_max_distance_m", scene.multipath_max_distance_m, {0.0, 100.0});

  WallOptions wall_defaults;
  OptionsNode defaults = node.child("wall_defaults");
  read_wall_keys(defaults, wall_defaults);
  defaults.finish();

  OptionsNode walls = node.child("walls");
  for (const auto& name : lister.keys({"scene", "walls"})) {
    OptionsNode n = walls.child(name, true);
    WallOptions w = wall_defaults;
    w.name = name;
    read_points(n, "points", w.points, 2, true);
    n.read("closed", w.closed);
    read_wall_keys(n, w);
    n.read("mirror_loss_db", w.mirror_loss_db, {0.0, 100.0});
    n.finish();
    scene.walls.push_back(std::move(w));
  }
  walls.finish();

  OptionsNode boxes = node.child("boxes");
  for (const auto& name : lister.keys({"scene", "boxes"})) {
    OptionsNode n = boxes.child(name, true);
    BoxOptions b;
    b.name = name;
    if (!n.has("center")) n.fail("center", "[x, y] in m (the key is required)");
    read_vector2(n, "center", b.center);
    if (!n.has("size_m")) n.fail("size_m", "[length, width, height] in m (the key is required)");
    read_vector3(n, "size_m", b.size, "[length, width, height] in m");
    if (!(b.size.minCoeff() > 0)) n.fail("size_m", "positive length, width and height");
    n.read("yaw_deg", b.yaw_deg, {-360.0, 360.0});
    n.read("spacing_m", b.spacing_m, {0.01, 10.0});
    n.read("rcs_m2", b.rcs_m2, {0.0, 1e4});
    n.read("corner_rcs_m2", b.corner_rcs_m2, {0.0, 1e4});
    n.read("jitter_m", b.jitter_m, {0.0, 1.0});
    n.read("incidence_exponent", b.incidence_exponent, {0.0, 100.0});
    n.finish();
    scene.boxes.push_back(b);
  }
  boxes.finish();

  OptionsNode pillars = node.child("pillars");
  for (const auto& name : lister.keys({"scene", "pillars"})) {
    OptionsNode n = pillars.child(name, true);
    PillarOptions p;
    p.name = name;
    if (!n.has("center")) n.fail("center", "[x, y] in m (the key is required)");
    read_vector2(n, "center", p.center);
    n.read("radius_m", p.radius_m, {0.01, 10.0});
    n.read("height_m", p.height_m, {0.05, 100.0});
    n.read("spacing_m", p.spacing_m, {0.01, 10.0});
    n.read("row_spacing_m", p.row_spacing_m, {0.01, 10.0});
    n.read("rcs_m2", p.rcs_m2, {0.0, 1e4});
    n.read("jitter_m", p.jitter_m, {0.0, 1.0});
    n.read("incidence_exponent", p.incidence_exponent, {0.0, 100.0});
    n.finish();
    scene.pillars.push_back(p);
  }
  pillars.finish();

  OptionsNode clutter = node.child("clutter");
  for (const auto& name : lister.keys({"scene", "clutter"})) {
    OptionsNode n = clutter.child(name, true);
    ClutterOptions c;
    c.name = name;
    if (!n.has("region")) n.fail("region", "[x_min, y_min, x_max, y_max] in m (the key is required)");
    std::vector<double> region;
    n.read("region", region);
    if (region.size() != 4 || region[2] < region[0] || region[3] < region[1])
      n.fail("region", "[x_min, y_min, x_max, y_max] in m with min <= max");
    c.region = Eigen::Vector4d(region[0], region[1], region[2], region[3]);
    n.read("count", c.count, {0, 1000000});
    std::vector<double> z{c.z_min_m, c.z_max_m};
    n.read("z_range_m", z);
    if (z.size() != 2 || z[1] < z[0] || z[0] < 0) n.fail("z_range_m", "[z_min, z_max] in m, 0 <= z_min <= z_max");
    c.z_min_m = z[0];
    c.z_max_m = z[1];
    n.read("rcs_m2", c.rcs_m2, {0.0, 1e4});
    n.finish();
    scene.clutter.push_back(c);
  }
  clutter.finish();

  OptionsNode people = node.child("people");
  for (const auto& name : lister.keys({"scene", "people"})) {
    OptionsNode n = people.child(name, true);
    PersonOptions p;
    p.name = name;
    read_points(n, "path", p.path, 2, true);
    n.read("speed_mps", p.speed_mps, {0.05, 5.0});
    n.read("loop", p.loop);
    n.read("start_s", p.start_s, {0.0, 1e6});
    n.read("pause_s", p.pause_s, {0.0, 1e4});
    n.read("height_m", p.height_m, {0.3, 2.5});
    n.read("rcs_m2", p.rcs_m2, {0.0, 100.0});
    n.finish();
    scene.people.push_back(std::move(p));
  }
  people.finish();
  node.finish();
}

void read_trajectory(OptionsNode node, TrajectoryOptions& t) {
  read_points(node, "waypoints", t.waypoints, 2, true);
  node.read("speed_mps", t.speed_mps, {0.01, 10.0});
  node.read("segment_speeds_mps", t.segment_speeds_mps);
  if (node.has("segment_speeds_mps")) {
    if (t.segment_speeds_mps.size() != t.waypoints.size() - 1)
      node.fail("segment_speeds_mps", "one speed per segment (" + std::to_string(t.waypoints.size() - 1) +
                                          " for " + std::to_string(t.waypoints.size()) + " waypoints), got " +
                                          std::to_string(t.segment_speeds_mps.size()));
    for (double v : t.segment_speeds_mps)
      if (!(v >= 0.01 && v <= 10.0)) node.fail("segment_speeds_mps", "speeds in [0.01, 10] m/s");
  }
  node.read("pauses_s", t.pauses_s);
  if (node.has("pauses_s")) {
    if (t.pauses_s.size() != t.waypoints.size())
      node.fail("pauses_s", "one pause per waypoint (" + std::to_string(t.waypoints.size()) + "), got " +
                                std::to_string(t.pauses_s.size()));
    for (double p : t.pauses_s)
      if (!(p >= 0 && p <= 1e4)) node.fail("pauses_s", "pauses in [0, 10000] s");
  }
  node.read("knot_interval_s", t.knot_interval_s, {0.05, 10.0});
  node.read("turn_distance_m", t.turn_distance_m, {0.0, 100.0});
  node.read("still_start_s", t.still_start_s, {0.0, 1e4});
  node.read("still_end_s", t.still_end_s, {0.0, 1e4});
  node.read("bob_amplitude_m", t.bob_amplitude_m, {0.0, 0.2});
  node.read("roll_amplitude_deg", t.roll_amplitude_deg, {0.0, 20.0});
  node.read("pitch_amplitude_deg", t.pitch_amplitude_deg, {0.0, 20.0});
  node.read("step_frequency_hz", t.step_frequency_hz, {0.1, 5.0});
  node.finish();
}

void read_radar_model(OptionsNode node, RadarModelOptions& m) {
  node.read("tx_power_dbm", m.tx_power_dbm, {-30.0, 40.0});
  node.read("tx_gain_dbi", m.tx_gain_dbi, {-20.0, 50.0});
  node.read("rx_gain_dbi", m.rx_gain_dbi, {-20.0, 50.0});
  node.read("noise_figure_db", m.noise_figure_db, {0.0, 50.0});
  node.read("system_loss_db", m.system_loss_db, {0.0, 100.0});
  node.read("noise_rms_lsb", m.noise_rms_lsb, {1e-3, 10000.0});
  node.read("thermal_noise", m.thermal_noise);
  node.read("azimuth_beamwidth_deg", m.azimuth_beamwidth_deg, {1.0, 360.0});
  node.read("elevation_beamwidth_deg", m.elevation_beamwidth_deg, {1.0, 360.0});
  node.read("if_highpass_khz", m.if_highpass_khz, {0.0, 10000.0});
  node.read("if_passband_fraction", m.if_passband_fraction, {0.1, 1.0});
  node.read("leakage_amplitude_lsb", m.leakage_amplitude_lsb, {0.0, 30000.0});
  node.read("leakage_range_m", m.leakage_range_m, {0.0, 10.0});
  node.read("channel_gain_error_db", m.channel_gain_error_db, {0.0, 20.0});
  node.read("channel_phase_error_deg", m.channel_phase_error_deg, {0.0, 180.0});
  node.read("min_range_m", m.min_range_m, {0.0, 100.0});
  node.read("occlusion", m.occlusion);
  node.read("first_frame_s", m.first_frame_s, {0.0, 1e4});
  node.finish();
}

void read_imu(OptionsNode node, ImuOptions& imu) {
  node.read("rate_hz", imu.rate_hz, {10.0, 10000.0});
  node.read("gyro_noise_density", imu.gyro_noise_density, {0.0, 1.0});
  node.read("accel_noise_density", imu.accel_noise_density, {0.0, 10.0});
  node.read("gyro_bias_random_walk", imu.gyro_bias_random_walk, {0.0, 1.0});
  node.read("accel_bias_random_walk", imu.accel_bias_random_walk, {0.0, 10.0});
  node.read("gyro_bias_sigma", imu.gyro_bias_sigma, {0.0, 10.0});
  node.read("accel_bias_sigma", imu.accel_bias_sigma, {0.0, 10.0});
  node.read("gravity_mps2", imu.gravity_mps2, {0.0, 100.0});
  node.finish();
}

void read_rig(OptionsNode node, Scenario& s) {
  node.read("height_m", s.trajectory.height_m, {0.0, 10.0});
  read_vector3(node, "radar_translation_m", s.rig.radar_in_imu.translation, "[x, y, z] in m");
  Eigen::Vector3d rpy = Eigen::Vector3d::Zero();
  read_vector3(node, "radar_rpy_deg", rpy, "[roll, pitch, yaw] in degrees");
  if (rpy.cwiseAbs().maxCoeff() > 360) node.fail("radar_rpy_deg", "angles in [-360, 360] degrees");
  s.rig.radar_in_imu.rotation = rotation_from_rpy(rpy.x() * kDeg, rpy.y() * kDeg, rpy.z() * kDeg);
  node.read("imu_time_offset_s", s.rig.imu_time_offset_s, {-1.0, 1.0});
  node.finish();
}

}  // namespace

Scenario load_scenario(const std::string& path) {
  OptionsFile file(path);
  OptionsNode root = file.root();
  const KeyLister lister(path);
  Scenario s;
  s.file = path;
  s.name = std::filesystem::path(path).stem().string();
  root.read("name", s.name);
  root.read("description", s.description);
  int seed = 1;
  root.read("seed", seed, {0, std::numeric_limits<int>::max()});
  s.seed = static_cast<std::uint64_t>(seed);
  root.read("duration_s", s.duration_s, {0.0, 1e6});
  root.read("start_time_unix_s", s.start_time_unix_s, {0.0, 4e9});
  OptionsNode radar = root.child("radar", true);
  s.radar = load_radar_config(radar);
  read_radar_model(root.child("radar_model"), s.radar_model);
  read_rig(root.child("rig"), s);
  read_imu(root.child("imu"), s.imu);
  read_trajectory(root.child("trajectory", true), s.trajectory);
  read_scene(root.child("scene"), lister, s.scene);
  root.finish();
  return s;
}

}  // namespace rsrio::sim
