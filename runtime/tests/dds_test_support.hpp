// What the tests that run real Fast DDS participants on loopback share.
#pragma once

#include <string>

#include <unistd.h>

#include <fastdds/dds/core/status/PublicationMatchedStatus.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>

#include "rsrio/runtime/dds.hpp"

namespace rsrio::testing {

/// Options for a participant named `name` in a domain of this process's own, so that parallel
/// test processes do not see each other.
inline DdsOptions loopback_options(const std::string& name) {
  DdsOptions o;
  o.domain_id = 100 + static_cast<int>(::getpid() % 40);  // 100-139 (daemon_end_to_end.sh lists the ranges)
  o.participant_name = name;
  return o;
}

/// How many readers `writer` is matched with now.
inline int matched_readers(eprosima::fastdds::dds::DataWriter* writer) {
  eprosima::fastdds::dds::PublicationMatchedStatus s;
  writer->get_publication_matched_status(s);
  return s.current_count;
}

}  // namespace rsrio::testing
