// Remote readers and writers that DDS does not match with the service's because their
// QoS is incompatible: without this, a client written from docs/PROTOCOL.md that got one
// policy wrong (a SHARED ContactForces reader, a VOLATILE topology writer, a writer
// without a lease) just hears nothing. The monitor polls the DDS "incompatible QoS"
// statuses of the service's readers and writers (Service, once per heartbeat) and turns
// each new mismatch into a message naming the topic, the policy and what the protocol
// asks for; the service logs it and publishes it as a ServiceStatus KIND_ERROR, which
// such a client does receive (a ServiceStatus reader with DDS's default QoS matches the
// service's writer).
#pragma once

#include <dds/dds.h>

#include <string>
#include <vector>

#include "protocol.hpp"

namespace tc::daemon {

class IncompatibleQosMonitor {
 public:
  /// The service's reader of `topic`: remote writers offering less than it requests.
  void add_reader(dds_entity_t reader, protocol::Topic topic);
  /// The service's writer of `topic`: remote readers requesting more than it offers.
  void add_writer(dds_entity_t writer, protocol::Topic topic);

  /// One message per entity whose count of incompatible remote endpoints grew since the
  /// last poll (reading the status resets DDS's change counter).
  std::vector<std::string> poll();

 private:
  struct Watched {
    dds_entity_t entity;
    protocol::Topic topic;
    bool reader;
  };
  std::vector<Watched> watched_;
};

/// Upper-case name of a DDS QoS policy id ("OWNERSHIP", "LIVELINESS"), "policy <id>"
/// for one this code does not know.
std::string qos_policy_name(dds_qos_policy_id_t id);

/// What the protocol asks of the remote side of `topic` for `policy` (docs/PROTOCOL.md).
std::string qos_hint(protocol::Topic topic, dds_qos_policy_id_t policy, bool remote_is_reader);

}  // namespace tc::daemon
