#include "qos_check.hpp"

namespace tc::daemon {

void IncompatibleQosMonitor::add_reader(dds_entity_t reader, protocol::Topic topic) {
  watched_.push_back({reader, topic, true});
}

void IncompatibleQosMonitor::add_writer(dds_entity_t writer, protocol::Topic topic) {
  watched_.push_back({writer, topic, false});
}

std::vector<std::string> IncompatibleQosMonitor::poll() {
  std::vector<std::string> out;
  for (const Watched& w : watched_) {
    std::uint32_t total = 0;
    std::int32_t change = 0;
    dds_qos_policy_id_t policy = DDS_INVALID_QOS_POLICY_ID;
    if (w.reader) {
      dds_requested_incompatible_qos_status_t st{};
      if (dds_get_requested_incompatible_qos_status(w.entity, &st) < 0) continue;
      total = st.total_count;
      change = st.total_count_change;
      policy = static_cast<dds_qos_policy_id_t>(st.last_policy_id);
    } else {
      dds_offered_incompatible_qos_status_t st{};
      if (dds_get_offered_incompatible_qos_status(w.entity, &st) < 0) continue;
      total = st.total_count;
      change = st.total_count_change;
      policy = static_cast<dds_qos_policy_id_t>(st.last_policy_id);
    }
    if (change <= 0) continue;
    const char* remote = w.reader ? "writer" : "reader";
    out.push_back(std::string(protocol::topic_name(w.topic)) + ": " + std::to_string(change) +
                  " remote " + remote + (change == 1 ? "" : "s") +
                  " with incompatible QoS not matched (" + std::to_string(total) +
                  " so far; last policy " + qos_policy_name(policy) +
                  "): " + qos_hint(w.topic, policy, !w.reader) + " (docs/PROTOCOL.md, Topics)");
  }
  return out;
}

std::string qos_policy_name(dds_qos_policy_id_t id) {
  switch (id) {
    case DDS_DURABILITY_QOS_POLICY_ID:
      return "DURABILITY";
    case DDS_PRESENTATION_QOS_POLICY_ID:
      return "PRESENTATION";
    case DDS_DEADLINE_QOS_POLICY_ID:
      return "DEADLINE";
    case DDS_LATENCYBUDGET_QOS_POLICY_ID:
      return "LATENCY_BUDGET";
    case DDS_OWNERSHIP_QOS_POLICY_ID:
      return "OWNERSHIP";
    case DDS_LIVELINESS_QOS_POLICY_ID:
      return "LIVELINESS";
    case DDS_PARTITION_QOS_POLICY_ID:
      return "PARTITION";
    case DDS_RELIABILITY_QOS_POLICY_ID:
      return "RELIABILITY";
    case DDS_DESTINATIONORDER_QOS_POLICY_ID:
      return "DESTINATION_ORDER";
    case DDS_TYPE_CONSISTENCY_ENFORCEMENT_QOS_POLICY_ID:
      return "TYPE_CONSISTENCY_ENFORCEMENT";
    case DDS_DATA_REPRESENTATION_QOS_POLICY_ID:
      return "DATA_REPRESENTATION";
    default:
      return "policy " + std::to_string(static_cast<int>(id));
  }
}

std::string qos_hint(protocol::Topic topic, dds_qos_policy_id_t policy, bool remote_is_reader) {
  const bool answers = topic == protocol::Topic::kForces || topic == protocol::Topic::kStats;
  switch (policy) {
    case DDS_OWNERSHIP_QOS_POLICY_ID:
      return answers ? "the answer topics have EXCLUSIVE ownership (protocol version 2): a "
                       "reader must set ownership EXCLUSIVE"
                     : "this topic has SHARED ownership (the default)";
    case DDS_LIVELINESS_QOS_POLICY_ID:
      return remote_is_reader ? "a reader must request a liveliness lease of 1 s or more "
                                "(AUTOMATIC)"
                              : "a writer must offer AUTOMATIC liveliness with a lease of 1 s "
                                "or less (the DDS default, an infinite lease, is too long)";
    case DDS_DURABILITY_QOS_POLICY_ID:
      return remote_is_reader ? "a reader may request at most what this topic offers"
                              : "a MeshTopology writer must offer TRANSIENT_LOCAL durability "
                                "(a restarted service gets the topology back from it)";
    case DDS_RELIABILITY_QOS_POLICY_ID:
      return "every topic is RELIABLE";
    default:
      return "use the QoS of the protocol's table";
  }
}

}  // namespace tc::daemon
