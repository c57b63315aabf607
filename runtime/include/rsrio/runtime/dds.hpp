// DDS for rsrio: a DomainParticipant with the project's transport rules and QoS presets, so that
// every program (daemon, recorder, echo, tests) talks DDS the same way.
//
// QoS presets (ROS 2 names in brackets, so a ROS 2 subscriber knows what to ask for):
//   kOdometry    RELIABLE, VOLATILE, KEEP_LAST 10 [ROS 2 default "reliable"]: poses, odometry.
//                ROS 2 "sensor data" (best-effort) subscribers match it too.
//   kSensorData  BEST_EFFORT, VOLATILE, KEEP_LAST 5 [rclcpp SensorDataQoS]: IMU in, raw frames.
//   kLatched     RELIABLE, TRANSIENT_LOCAL, KEEP_LAST 1 ["transient local"]: status; a late
//                subscriber gets the last sample.
// Transports: loopback-only UDPv4 by default (127.0.0.1 only; works between processes of
// different users, unlike shared memory under systemd's DynamicUser), or Fast DDS's default
// UDPv4 + shared memory on every interface when loopback_only is false.
#pragma once

#include <memory>
#include <string>

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>

namespace rsrio {

struct DdsOptions {
  int domain_id = 0;           // ROS_DOMAIN_ID
  bool loopback_only = true;   // UDPv4 on 127.0.0.1 only
  std::string participant_name = "rsrio";
};

enum class QosPreset { kOdometry, kSensorData, kLatched };

eprosima::fastdds::dds::DataWriterQos writer_qos(QosPreset preset);
eprosima::fastdds::dds::DataReaderQos reader_qos(QosPreset preset);
const char* to_string(QosPreset preset);

/// ROS 2 topic name -> DDS topic name: "/rsrio/odom" -> "rt/rsrio/odom".
std::string ros_topic_to_dds(const std::string& ros_name);

/// Owns a DomainParticipant with one publisher and one subscriber; deletes everything it made.
class DdsParticipant {
 public:
  /// Throws std::runtime_error when Fast DDS refuses to create the participant.
  explicit DdsParticipant(const DdsOptions& options);
  ~DdsParticipant();
  DdsParticipant(const DdsParticipant&) = delete;
  DdsParticipant& operator=(const DdsParticipant&) = delete;

  /// A writer on `topic` (DDS name, e.g. "rt/rsrio/odom") for `type` (registered on first use).
  eprosima::fastdds::dds::DataWriter* make_writer(const std::string& topic,
                                                  eprosima::fastdds::dds::TypeSupport type,
                                                  QosPreset qos);
  eprosima::fastdds::dds::DataReader* make_reader(const std::string& topic,
                                                  eprosima::fastdds::dds::TypeSupport type, QosPreset qos,
                                                  eprosima::fastdds::dds::DataReaderListener* listener = nullptr);
  /// Deletes a reader made here (its listener is called no more once this returns: Fast DDS disables
  /// the reader and waits for a callback in progress). What a listener that dies before the
  /// participant calls first.
  void delete_reader(eprosima::fastdds::dds::DataReader* reader);

  eprosima::fastdds::dds::DomainParticipant* get() const { return participant_; }

 private:
  eprosima::fastdds::dds::Topic* topic(const std::string& name, eprosima::fastdds::dds::TypeSupport& type);

  eprosima::fastdds::dds::DomainParticipant* participant_ = nullptr;
  eprosima::fastdds::dds::Publisher* publisher_ = nullptr;
  eprosima::fastdds::dds::Subscriber* subscriber_ = nullptr;
};

}  // namespace rsrio
