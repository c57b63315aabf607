#include "rsrio/runtime/dds.hpp"

#include <stdexcept>

#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/domain/qos/DomainParticipantQos.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.hpp>

namespace rsrio {

namespace dds = eprosima::fastdds::dds;

namespace {

template <typename Qos>
void apply(Qos& q, QosPreset preset) {
  switch (preset) {
    case QosPreset::kOdometry:
      q.reliability().kind = dds::RELIABLE_RELIABILITY_QOS;
      q.durability().kind = dds::VOLATILE_DURABILITY_QOS;
      q.history().kind = dds::KEEP_LAST_HISTORY_QOS;
      q.history().depth = 10;
      break;
    case QosPreset::kSensorData:
      q.reliability().kind = dds::BEST_EFFORT_RELIABILITY_QOS;
      q.durability().kind = dds::VOLATILE_DURABILITY_QOS;
      q.history().kind = dds::KEEP_LAST_HISTORY_QOS;
      q.history().depth = 5;
      break;
    case QosPreset::kLatched:
      q.reliability().kind = dds::RELIABLE_RELIABILITY_QOS;
      q.durability().kind = dds::TRANSIENT_LOCAL_DURABILITY_QOS;
      q.history().kind = dds::KEEP_LAST_HISTORY_QOS;
      q.history().depth = 1;
      break;
  }
}

}  // namespace

dds::DataWriterQos writer_qos(QosPreset preset) {
  dds::DataWriterQos q = dds::DATAWRITER_QOS_DEFAULT;
  apply(q, preset);
  return q;
}

dds::DataReaderQos reader_qos(QosPreset preset) {
  dds::DataReaderQos q = dds::DATAREADER_QOS_DEFAULT;
  apply(q, preset);
  return q;
}

const char* to_string(QosPreset preset) {
  switch (preset) {
    case QosPreset::kOdometry: return "reliable, volatile, keep last 10";
    case QosPreset::kSensorData: return "best effort, volatile, keep last 5";
    case QosPreset::kLatched: return "reliable, transient local, keep last 1";
  }
  return "?";
}

std::string ros_topic_to_dds(const std::string& ros_name) {
  if (ros_name.empty() || ros_name.front() != '/') return "rt/" + ros_name;
  return "rt" + ros_name;
}

DdsParticipant::DdsParticipant(const DdsOptions& options) {
  dds::DomainParticipantQos pqos = dds::PARTICIPANT_QOS_DEFAULT;
  pqos.name(options.participant_name);
  if (options.loopback_only) {
    auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
    udp->interface_allowlist.emplace_back("127.0.0.1");
    pqos.transport().user_transports.push_back(udp);
    pqos.transport().use_builtin_transports = false;
  }
  participant_ = dds::DomainParticipantFactory::get_instance()->create_participant(
      static_cast<dds::DomainId_t>(options.domain_id), pqos);
  if (!participant_)
    throw std::runtime_error("Fast DDS could not create a participant on domain " +
                             std::to_string(options.domain_id));
  publisher_ = participant_->create_publisher(dds::PUBLISHER_QOS_DEFAULT);
  subscriber_ = participant_->create_subscriber(dds::SUBSCRIBER_QOS_DEFAULT);
  if (!publisher_ || !subscriber_) {
    participant_->delete_contained_entities();
    dds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
    throw std::runtime_error("Fast DDS could not create a publisher/subscriber");
  }
}

DdsParticipant::~DdsParticipant() {
  participant_->delete_contained_entities();
  dds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
}

dds::Topic* DdsParticipant::topic(const std::string& name, dds::TypeSupport& type) {
  if (participant_->find_type(type.get_type_name()).empty()) {
    if (type.register_type(participant_) != dds::RETCODE_OK)
      throw std::runtime_error("Fast DDS could not register type " + type.get_type_name());
  }
  if (auto* existing = dynamic_cast<dds::Topic*>(participant_->lookup_topicdescription(name))) return existing;
  dds::Topic* t = participant_->create_topic(name, type.get_type_name(), dds::TOPIC_QOS_DEFAULT);
  if (!t) throw std::runtime_error("Fast DDS could not create topic " + name);
  return t;
}

dds::DataWriter* DdsParticipant::make_writer(const std::string& topic_name, dds::TypeSupport type, QosPreset qos) {
  dds::DataWriter* w = publisher_->create_datawriter(topic(topic_name, type), writer_qos(qos));
  if (!w) throw std::runtime_error("Fast DDS could not create a writer on " + topic_name);
  return w;
}

dds::DataReader* DdsParticipant::make_reader(const std::string& topic_name, dds::TypeSupport type, QosPreset qos,
                                             dds::DataReaderListener* listener) {
  dds::DataReader* r = subscriber_->create_datareader(topic(topic_name, type), reader_qos(qos), listener);
  if (!r) throw std::runtime_error("Fast DDS could not create a reader on " + topic_name);
  return r;
}

void DdsParticipant::delete_reader(dds::DataReader* reader) {
  if (reader != nullptr && subscriber_->delete_datareader(reader) != dds::RETCODE_OK)
    throw std::runtime_error("Fast DDS could not delete a reader");
}

}  // namespace rsrio
