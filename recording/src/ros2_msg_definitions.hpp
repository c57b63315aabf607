// The ROS 2 .msg definitions of every type rsrio records, and the "ros2msg" schema text MCAP
// stores for a type: its .msg followed by each dependency, as rosbag2 writes it.
//
// The definitions mirror idl/ (the IDL is authoritative: CDR has no field names, so a reader that
// decodes with the embedded schema gets garbage unless field order and types match exactly);
// recording_test checks them against the IDL files field for field.
#pragma once

#include <span>
#include <string>
#include <string_view>

namespace rsrio::recording_detail {

struct MsgDefinition {
  std::string_view type_name;  // "pkg/msg/Type"
  std::string_view text;       // the .msg file
};

/// Every definition the recorder can embed (the recorded types and their dependencies).
std::span<const MsgDefinition> msg_definitions();

/// The .msg text of `type_name` ("pkg/msg/Type"); empty when unknown.
std::string_view msg_definition(std::string_view type_name);

/// The schema data for `type_name`: its .msg text, then every type it depends on (depth first,
/// dependencies of a type in sorted order, each once), each introduced by "\n", a line of 80 '='
/// and "MSG: pkg/Type" (the name as the .msg refers to it, as rosbag2's message definition cache
/// writes it). Throws std::invalid_argument for a type without a definition.
std::string ros2msg_schema(std::string_view type_name);

}  // namespace rsrio::recording_detail
