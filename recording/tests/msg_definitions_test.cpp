// The .msg texts embedded as schemas must match the IDL the C++ types are generated from, field
// for field and constant for constant (CDR carries no names: a reader decoding with a schema that
// differs in one field misreads everything after it). And the schema text has rosbag2's layout.
#include <algorithm>
#include <cctype>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <catch2/catch_test_macros.hpp>

#include "ros2_msg_definitions.hpp"

using rsrio::recording_detail::msg_definition;
using rsrio::recording_detail::msg_definitions;
using rsrio::recording_detail::ros2msg_schema;

namespace {

struct Member {
  std::string type;  // canonical: "float64", "pkg/msg/Type", with "[]" or "[N]"
  std::string name;
  bool operator==(const Member&) const = default;
};

struct Constant {
  std::string type;
  std::string name;
  std::string value;
  bool operator==(const Constant&) const = default;
};

struct Shape {
  std::vector<Member> members;
  std::vector<Constant> constants;
};

std::string trim(const std::string& s) {
  const auto first = s.find_first_not_of(" \t\r\n");
  if (first == std::string::npos) return {};
  return s.substr(first, s.find_last_not_of(" \t\r\n") - first + 1);
}

std::string canonical_primitive(const std::string& idl_type) {
  if (idl_type == "double") return "float64";
  if (idl_type == "float") return "float32";
  if (idl_type == "boolean") return "bool";
  if (idl_type == "octet") return "byte";
  return idl_type;  // int8..uint64, string
}

// "geometry_msgs::msg::Pose" -> "geometry_msgs/msg/Pose"; primitives mapped to .msg names.
std::string canonical_idl_type(std::string type) {
  if (type.find("::") == std::string::npos) return canonical_primitive(type);
  for (std::size_t at; (at = type.find("::")) != std::string::npos;) type.replace(at, 2, "/");
  return type;
}

// Whitespace-separated words (std::regex is avoided: GCC 14 warns inside <regex> under the
// sanitizers, and warnings are errors).
std::vector<std::string> words(const std::string& text) {
  std::vector<std::string> out;
  std::string word;
  for (char c : text) {
    if (std::isspace(static_cast<unsigned char>(c))) {
      if (!word.empty()) out.push_back(word);
      word.clear();
    } else {
      word += c;
    }
  }
  if (!word.empty()) out.push_back(word);
  return out;
}

Shape parse_idl(const std::string& path, const std::string& struct_name) {
  std::ifstream in(path);
  REQUIRE(in.good());
  std::string text;
  for (std::string line; std::getline(in, line);) {
    line = line.substr(0, line.find("//"));
    if (trim(line).rfind('#', 0) == 0) continue;  // preprocessor
    text += line + "\n";
  }
  Shape shape;
  // const <type> <NAME> = <value>;
  for (std::size_t at = 0; (at = text.find("const ", at)) != std::string::npos;) {
    const std::size_t semicolon = text.find(';', at);
    const std::string declaration = text.substr(at + 6, semicolon - at - 6);
    const std::size_t equals = declaration.find('=');
    const std::vector<std::string> left = words(declaration.substr(0, equals));
    REQUIRE(left.size() == 2);
    shape.constants.push_back({canonical_primitive(left[0]), left[1], trim(declaration.substr(equals + 1))});
    at = semicolon;
  }

  const std::size_t struct_at = text.find("struct " + struct_name);
  REQUIRE(struct_at != std::string::npos);
  const std::size_t open = text.find('{', struct_at);
  const std::size_t close = text.find('}', open);
  const std::string members = text.substr(open + 1, close - open - 1);
  std::size_t start = 0;
  for (std::size_t semicolon; (semicolon = members.find(';', start)) != std::string::npos; start = semicolon + 1) {
    std::string declaration = trim(members.substr(start, semicolon - start));
    INFO(path << ": " << declaration);
    std::string type;
    if (declaration.rfind("sequence<", 0) == 0) {  // sequence<T> name
      const std::size_t end = declaration.find('>');
      type = canonical_idl_type(trim(declaration.substr(9, end - 9))) + "[]";
      declaration = declaration.substr(end + 1);
    } else {
      const std::vector<std::string> parts = words(declaration);
      REQUIRE(parts.size() >= 2);
      type = canonical_idl_type(parts[0]);
      declaration = declaration.substr(declaration.find(parts[0]) + parts[0].size());
    }
    std::string name = trim(declaration);  // name or name[N]
    if (const std::size_t bracket = name.find('['); bracket != std::string::npos) {
      type += "[" + trim(name.substr(bracket + 1, name.find(']') - bracket - 1)) + "]";
      name = trim(name.substr(0, bracket));
    }
    REQUIRE(words(name).size() == 1);
    shape.members.push_back({type, name});
  }
  return shape;
}

Shape parse_msg(std::string_view text, const std::string& package) {
  static const std::vector<std::string> kPrimitives = {"bool",   "byte",  "char",   "float32", "float64",
                                                       "int8",   "uint8", "int16",  "uint16",  "int32",
                                                       "uint32", "int64", "uint64", "string"};
  Shape shape;
  std::string all(text);
  std::size_t start = 0;
  while (start < all.size()) {
    std::size_t end = all.find('\n', start);
    if (end == std::string::npos) end = all.size();
    std::string line = all.substr(start, end - start);
    start = end + 1;
    line = trim(line.substr(0, line.find('#')));
    if (line.empty()) continue;
    if (const auto equals = line.find('='); equals != std::string::npos) {  // type NAME=value
      const std::vector<std::string> left = words(line.substr(0, equals));
      REQUIRE(left.size() == 2);
      shape.constants.push_back({left[0], left[1], trim(line.substr(equals + 1))});
      continue;
    }
    const std::vector<std::string> parts = words(line);  // type[N] name [default]
    INFO(package << ": " << line);
    REQUIRE((parts.size() == 2 || parts.size() == 3));
    std::string type = parts[0];
    std::string array;
    if (const std::size_t bracket = type.find('['); bracket != std::string::npos) {
      array = type.substr(bracket);
      type = type.substr(0, bracket);
    }
    if (std::find(kPrimitives.begin(), kPrimitives.end(), type) == kPrimitives.end()) {
      if (type.find('/') == std::string::npos) type = package + "/" + type;
      if (type.find("/msg/") == std::string::npos) type.insert(type.find('/'), "/msg");
    }
    shape.members.push_back({type + array, parts[1]});
  }
  return shape;
}

}  // namespace

TEST_CASE("recording: every embedded .msg matches its IDL field for field", "[recording][schema]") {
  REQUIRE(msg_definitions().size() >= 16);
  for (const auto& definition : msg_definitions()) {
    const std::string type_name(definition.type_name);
    INFO(type_name);
    const std::string package = type_name.substr(0, type_name.find('/'));
    const std::string struct_name = type_name.substr(type_name.rfind('/') + 1);
    const std::string idl_path = std::string(RSRIO_IDL_DIR) + "/" + type_name + ".idl";
    const Shape idl = parse_idl(idl_path, struct_name);
    const Shape msg = parse_msg(definition.text, package);
    REQUIRE(!idl.members.empty());
    CHECK(msg.members == idl.members);
    CHECK(msg.constants == idl.constants);
  }
}

TEST_CASE("recording: the IDL shapes of rsrio's own messages are what the parser sees", "[recording][schema]") {
  // Guards the test above against a parser that silently sees nothing.
  const Shape frame = parse_idl(std::string(RSRIO_IDL_DIR) + "/rsrio_msgs/msg/RadarFrame.idl", "RadarFrame");
  REQUIRE(frame.members.size() == 7);
  REQUIRE(frame.members.front() == Member{"std_msgs/msg/Header", "header"});
  REQUIRE(frame.members.back() == Member{"uint8[]", "adc"});
  REQUIRE(frame.constants.size() == 4);
  REQUIRE(frame.constants.front() == Constant{"uint32", "FLAG_DAMAGED", "1"});
  const Shape config = parse_idl(std::string(RSRIO_IDL_DIR) + "/rsrio_msgs/msg/RadarConfig.idl", "RadarConfig");
  REQUIRE(config.members.size() == 25);
}

TEST_CASE("recording: schemas concatenate dependencies as rosbag2 does", "[recording][schema]") {
  const std::string separator = "\n" + std::string(80, '=') + "\n";
  const std::string expected = std::string(msg_definition("sensor_msgs/msg/Imu")) +                       //
                               separator + "MSG: geometry_msgs/Quaternion\n" +                              //
                               std::string(msg_definition("geometry_msgs/msg/Quaternion")) +                //
                               separator + "MSG: geometry_msgs/Vector3\n" +                                 //
                               std::string(msg_definition("geometry_msgs/msg/Vector3")) +                   //
                               separator + "MSG: std_msgs/Header\n" +                                       //
                               std::string(msg_definition("std_msgs/msg/Header")) +                         //
                               separator + "MSG: builtin_interfaces/Time\n" +                               //
                               std::string(msg_definition("builtin_interfaces/msg/Time"));
  REQUIRE(ros2msg_schema("sensor_msgs/msg/Imu") == expected);

  // Each dependency once, even when reached twice (Pose through both covariances' parents).
  const std::string odometry = ros2msg_schema("nav_msgs/msg/Odometry");
  for (const char* type : {"MSG: geometry_msgs/Pose\n", "MSG: geometry_msgs/Point\n", "MSG: std_msgs/Header\n",
                           "MSG: geometry_msgs/Twist\n", "MSG: geometry_msgs/Vector3\n"}) {
    INFO(type);
    const auto first = odometry.find(type);
    REQUIRE(first != std::string::npos);
    REQUIRE(odometry.find(type, first + 1) == std::string::npos);
  }

  const std::string frame = ros2msg_schema("rsrio_msgs/msg/RadarFrame");
  REQUIRE(frame.find(separator + "MSG: rsrio_msgs/RadarConfig\n") != std::string::npos);
  REQUIRE(frame.find(separator + "MSG: std_msgs/Header\n") != std::string::npos);
  REQUIRE(frame.find(separator + "MSG: builtin_interfaces/Time\n") != std::string::npos);

  REQUIRE_THROWS_AS(ros2msg_schema("rsrio_msgs/msg/Unknown"), std::invalid_argument);
}
