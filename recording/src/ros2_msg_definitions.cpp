#include "ros2_msg_definitions.hpp"

#include <array>
#include <functional>
#include <set>
#include <stdexcept>

namespace rsrio::recording_detail {

namespace {

// Standard ROS 2 interfaces: the fields (and constants, defaults) of the upstream .msg files in
// their order. Dependencies are written the way the upstream files write them ("std_msgs/Header",
// same-package types unqualified), because that spelling ends up in the "MSG:" lines.
constexpr std::string_view kTime =
    "int32 sec\n"
    "uint32 nanosec\n";

constexpr std::string_view kHeader =
    "# Standard metadata for higher-level stamped data types.\n"
    "builtin_interfaces/Time stamp\n"
    "string frame_id\n";

constexpr std::string_view kPoint =
    "float64 x\n"
    "float64 y\n"
    "float64 z\n";

constexpr std::string_view kQuaternion =
    "float64 x 0\n"
    "float64 y 0\n"
    "float64 z 0\n"
    "float64 w 1\n";

constexpr std::string_view kVector3 =
    "float64 x\n"
    "float64 y\n"
    "float64 z\n";

constexpr std::string_view kPose =
    "Point position\n"
    "Quaternion orientation\n";

constexpr std::string_view kPoseStamped =
    "std_msgs/Header header\n"
    "Pose pose\n";

constexpr std::string_view kTwist =
    "Vector3 linear\n"
    "Vector3 angular\n";

constexpr std::string_view kPoseWithCovariance =
    "Pose pose\n"
    "# Row-major 6x6 covariance: x, y, z, rotation about X, Y, Z.\n"
    "float64[36] covariance\n";

constexpr std::string_view kTwistWithCovariance =
    "Twist twist\n"
    "# Row-major 6x6 covariance: x, y, z, rotation about X, Y, Z.\n"
    "float64[36] covariance\n";

constexpr std::string_view kOdometry =
    "std_msgs/Header header\n"
    "string child_frame_id\n"
    "geometry_msgs/PoseWithCovariance pose\n"
    "geometry_msgs/TwistWithCovariance twist\n";

constexpr std::string_view kImu =
    "std_msgs/Header header\n"
    "geometry_msgs/Quaternion orientation\n"
    "float64[9] orientation_covariance\n"
    "geometry_msgs/Vector3 angular_velocity\n"
    "float64[9] angular_velocity_covariance\n"
    "geometry_msgs/Vector3 linear_acceleration\n"
    "float64[9] linear_acceleration_covariance\n";

constexpr std::string_view kPointField =
    "uint8 INT8    = 1\n"
    "uint8 UINT8   = 2\n"
    "uint8 INT16   = 3\n"
    "uint8 UINT16  = 4\n"
    "uint8 INT32   = 5\n"
    "uint8 UINT32  = 6\n"
    "uint8 FLOAT32 = 7\n"
    "uint8 FLOAT64 = 8\n"
    "\n"
    "string name\n"
    "uint32 offset\n"
    "uint8 datatype\n"
    "uint32 count\n";

constexpr std::string_view kPointCloud2 =
    "std_msgs/Header header\n"
    "uint32 height\n"
    "uint32 width\n"
    "PointField[] fields\n"
    "bool is_bigendian\n"
    "uint32 point_step\n"
    "uint32 row_step\n"
    "uint8[] data\n"
    "bool is_dense\n";

// rsrio's own messages, transcribed from idl/rsrio_msgs/msg/*.idl (the IDL is authoritative; the
// comments are the IDL's, so a reader of the recording learns the units without our sources).
constexpr std::string_view kRadarConfig =
    "# The radar configuration a raw frame was captured with (rsrio SPEC Sec. 4), carried with every\n"
    "# frame so that a recording can be re-processed without outside files. Field meanings and units:\n"
    "# rsrio common/include/rsrio/common/radar_config.hpp.\n"
    "string preset\n"
    "float64 start_frequency_ghz\n"
    "float64 slope_mhz_per_us\n"
    "float64 adc_sample_rate_ksps\n"
    "uint32 samples_per_chirp\n"
    "float64 idle_time_us\n"
    "float64 adc_start_time_us\n"
    "float64 ramp_end_time_us\n"
    "# chirp loops per frame; each loop fires every TX of tx_order once\n"
    "uint32 loops\n"
    "# TDM slot -> TX id\n"
    "int32[] tx_order\n"
    "float64 frame_period_ms\n"
    "uint32 angle_fft_size\n"
    "# antenna positions in half-wavelengths at design_frequency_ghz\n"
    "float64 design_frequency_ghz\n"
    "int32[] tx_azimuth\n"
    "int32[] tx_elevation\n"
    "int32[] rx_azimuth\n"
    "int32[] rx_elevation\n"
    "# \"dca1000\" or \"mmwcas\"\n"
    "string capture_format\n"
    "# \"i_first\" or \"q_first\"\n"
    "string iq_order\n"
    "# \"iiqq\" or \"iq\"\n"
    "string sample_layout\n"
    "bool offset_binary\n"
    "uint8 lvds_lanes\n"
    "# per-channel calibration, indexed [tx_id * num_rx + rx]; empty means identity\n"
    "float64[] calibration_gain_re\n"
    "float64[] calibration_gain_im\n"
    "float64[] calibration_frequency_offset_hz\n";

constexpr std::string_view kRadarFrame =
    "# One raw ADC frame, byte for byte as the capture hardware delivered it (DCA1000 stream or\n"
    "# cascade device files), with its configuration and damage flags.\n"
    "\n"
    "# bytes were lost and zero-filled: never use as good data\n"
    "uint32 FLAG_DAMAGED=1\n"
    "# packets arrived out of order (placed by byte count)\n"
    "uint32 FLAG_OUT_OF_ORDER=2\n"
    "# duplicated packets were seen (dropped)\n"
    "uint32 FLAG_DUPLICATE=4\n"
    "# made by the simulator\n"
    "uint32 FLAG_SIMULATED=8\n"
    "\n"
    "# stamp: frame completion, CLOCK_REALTIME mapped from CLOCK_MONOTONIC\n"
    "std_msgs/Header header\n"
    "uint64 frame_number\n"
    "# CLOCK_MONOTONIC at frame completion\n"
    "uint64 monotonic_ns\n"
    "uint32 flags\n"
    "# zero-filled bytes in adc\n"
    "uint32 lost_bytes\n"
    "RadarConfig config\n"
    "uint8[] adc\n";

constexpr std::array kDefinitions = {
    MsgDefinition{"builtin_interfaces/msg/Time", kTime},
    MsgDefinition{"std_msgs/msg/Header", kHeader},
    MsgDefinition{"geometry_msgs/msg/Point", kPoint},
    MsgDefinition{"geometry_msgs/msg/Quaternion", kQuaternion},
    MsgDefinition{"geometry_msgs/msg/Vector3", kVector3},
    MsgDefinition{"geometry_msgs/msg/Pose", kPose},
    MsgDefinition{"geometry_msgs/msg/PoseStamped", kPoseStamped},
    MsgDefinition{"geometry_msgs/msg/Twist", kTwist},
    MsgDefinition{"geometry_msgs/msg/PoseWithCovariance", kPoseWithCovariance},
    MsgDefinition{"geometry_msgs/msg/TwistWithCovariance", kTwistWithCovariance},
    MsgDefinition{"nav_msgs/msg/Odometry", kOdometry},
    MsgDefinition{"sensor_msgs/msg/Imu", kImu},
    MsgDefinition{"sensor_msgs/msg/PointField", kPointField},
    MsgDefinition{"sensor_msgs/msg/PointCloud2", kPointCloud2},
    MsgDefinition{"rsrio_msgs/msg/RadarConfig", kRadarConfig},
    MsgDefinition{"rsrio_msgs/msg/RadarFrame", kRadarFrame},
};

constexpr std::string_view kPrimitiveTypes[] = {"bool",  "byte",   "char",  "float32", "float64",
                                                "int8",  "uint8",  "int16", "uint16",  "int32",
                                                "uint32", "int64", "uint64", "string", "wstring"};

bool is_primitive(std::string_view type) {
  for (std::string_view primitive : kPrimitiveTypes)
    if (type == primitive) return true;
  return false;
}

std::string_view trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t\r");
  if (first == std::string_view::npos) return {};
  const auto last = s.find_last_not_of(" \t\r");
  return s.substr(first, last - first + 1);
}

// The message types a .msg refers to, as "pkg/Type" (unqualified names get the package of the
// referring type), sorted: the order rosbag2 appends them in.
std::set<std::string> dependencies_of(std::string_view text, std::string_view package) {
  std::set<std::string> dependencies;
  while (!text.empty()) {
    const auto end = text.find('\n');
    std::string_view line = text.substr(0, end);
    text = end == std::string_view::npos ? std::string_view{} : text.substr(end + 1);
    line = trim(line.substr(0, line.find('#')));
    if (line.empty()) continue;
    std::string_view type = line.substr(0, line.find_first_of(" \t"));
    type = type.substr(0, type.find('['));       // float64[36], PointField[], string[<=5]
    type = type.substr(0, type.find("<="));      // bounded strings
    if (is_primitive(type)) continue;
    if (type.find('/') == std::string_view::npos)
      dependencies.insert(std::string(package) + "/" + std::string(type));
    else
      dependencies.insert(std::string(type));
  }
  return dependencies;
}

// "pkg/Type" or "pkg/msg/Type" -> "pkg/msg/Type".
std::string full_type_name(std::string_view name) {
  const auto slash = name.find('/');
  if (name.find('/', slash + 1) != std::string_view::npos) return std::string(name);
  return std::string(name.substr(0, slash)) + "/msg/" + std::string(name.substr(slash + 1));
}

}  // namespace

std::span<const MsgDefinition> msg_definitions() { return kDefinitions; }

std::string_view msg_definition(std::string_view type_name) {
  for (const MsgDefinition& definition : kDefinitions)
    if (definition.type_name == type_name) return definition.text;
  return {};
}

std::string ros2msg_schema(std::string_view type_name) {
  std::set<std::string> already_appended;
  std::function<std::string(std::string_view)> text_with_dependencies = [&](std::string_view name) {
    const std::string full_name = full_type_name(name);
    const std::string_view text = msg_definition(full_name);
    if (text.empty()) throw std::invalid_argument("no .msg definition for ROS 2 type '" + full_name + "'");
    std::string result(text);
    const std::string package = full_name.substr(0, full_name.find('/'));
    for (const std::string& dependency : dependencies_of(text, package)) {
      if (!already_appended.insert(dependency).second) continue;
      result += '\n';
      result += std::string(80, '=');
      result += "\nMSG: " + dependency + "\n";
      result += text_with_dependencies(dependency);
    }
    return result;
  };
  return text_with_dependencies(type_name);
}

}  // namespace rsrio::recording_detail
