#include "recorder.hpp"

#include <dds/dds.h>

#include <array>
#include <span>

#include "protocol.hpp"
#include "recording.hpp"
#include "status_event.hpp"
#include "take_all.hpp"
#include "tetcollide.h"

namespace tc::replay {
namespace {

using Clock = std::chrono::steady_clock;
/// The recorder keeps more history than the service so a burst is not lost while it
/// writes the file.
constexpr std::int32_t kRecorderDepth = 1000;

Error dds_error(const std::string& call, dds_return_t rc) {
  return Error{ErrorCode::kIo, call + ": " + protocol::dds_error(rc)};
}

/// Owns the participant; deleting it deletes every entity below.
struct Participant {
  dds_entity_t handle = 0;
  ~Participant() {
    if (handle > 0) dds_delete(handle);
  }
};

template <typename T>
std::vector<T> to_vector(const T* data, std::uint32_t n) {
  return n == 0 ? std::vector<T>{} : std::vector<T>(data, data + n);
}

/// Writes one taken sample of `topic` to the recording (taken at `t` seconds).
Status write_sample(RecordingWriter& writer, RecordSummary& summary, protocol::Topic topic,
                    const void* sample, const dds_sample_info_t& info, double t) {
  Status st;
  switch (topic) {
    case protocol::Topic::kTopology: {
      const auto* s = static_cast<const tetcollide_MeshTopology*>(sample);
      if (info.valid_data) {
        TopologyRecord r;
        r.t = t;
        r.scene = protocol::bounded_view(s->scene);
        r.object = protocol::bounded_view(s->object);
        r.version = s->version;
        r.mesh.node_ids = to_vector(s->node_ids._buffer, s->node_ids._length);
        r.mesh.rest_positions = to_vector(s->rest_positions._buffer, s->rest_positions._length);
        r.mesh.tets = to_vector(s->tets._buffer, s->tets._length);
        r.mesh.triangles = to_vector(s->triangles._buffer, s->triangles._length);
        r.params.stiffness = s->params.stiffness;
        r.params.damping = s->params.damping;
        r.params.max_force = s->params.max_force;
        r.params.is_static = s->params.is_static;
        r.params.depth = static_cast<client::DepthMethod>(s->params.depth);
        r.params.response = static_cast<client::ResponseKind>(s->params.response);
        r.params.friction = s->params.friction;
        r.params.friction_velocity = s->params.friction_velocity;
        r.params.blocks = s->params.blocks;
        r.params.contacts = s->params.contacts;
        r.params.self_contact = s->params.self_contact;
        st = writer.write(r);
        ++summary.topologies;
      }
      if (st && info.instance_state != DDS_IST_ALIVE) {
        st = writer.write(RemoveRecord{t, std::string(protocol::bounded_view(s->scene)),
                                       std::string(protocol::bounded_view(s->object))});
        ++summary.removals;
      }
      break;
    }
    case protocol::Topic::kState: {
      if (!info.valid_data) break;
      const auto* s = static_cast<const tetcollide_MeshState*>(sample);
      StateRecord r;
      r.t = t;
      r.scene = protocol::bounded_view(s->scene);
      r.object = protocol::bounded_view(s->object);
      r.frame = s->frame;
      r.topology_version = s->topology_version;
      r.positions = to_vector(s->positions._buffer, s->positions._length);
      r.velocities = to_vector(s->velocities._buffer, s->velocities._length);
      st = writer.write(r);
      ++summary.states;
      break;
    }
    case protocol::Topic::kForces: {
      if (!info.valid_data) break;
      const auto* s = static_cast<const tetcollide_ContactForces*>(sample);
      ForcesRecord r;
      r.t = t;
      r.scene = protocol::bounded_view(s->scene);
      r.object = protocol::bounded_view(s->object);
      r.frame = s->frame;
      r.topology_version = s->topology_version;
      r.status = s->status;
      r.nodes = to_vector(s->nodes._buffer, s->nodes._length);
      r.forces = to_vector(s->forces._buffer, s->forces._length);
      r.stiffness = to_vector(s->stiffness._buffer, s->stiffness._length);
      r.damping = to_vector(s->damping._buffer, s->damping._length);
      st = writer.write(r);
      ++summary.forces;
      break;
    }
    case protocol::Topic::kStatus: {
      if (!info.valid_data) break;
      const auto* s = static_cast<const tetcollide_ServiceStatus*>(sample);
      StatusRecord r;
      r.t = t;
      r.event = client::detail::status_event(*s);
      st = writer.write(r);
      ++summary.status;
      break;
    }
    case protocol::Topic::kStats:
      break;
  }
  return st;
}

}  // namespace

Expected<RecordSummary> record(const RecordOptions& options, const std::atomic<bool>& stop) {
  Participant participant;
  participant.handle = dds_create_participant(options.domain, nullptr, nullptr);
  if (participant.handle < 0) return dds_error("dds_create_participant", participant.handle);
  const dds_entity_t pp = participant.handle;
  const auto pqos = protocol::partition_qos(options.partition);
  const dds_entity_t subscriber = dds_create_subscriber(pp, pqos.get(), nullptr);
  if (subscriber < 0) return dds_error("dds_create_subscriber", subscriber);

  std::array<dds_entity_t, 4> readers{};
  const std::array<protocol::Topic, 4> topics{protocol::Topic::kTopology, protocol::Topic::kState,
                                              protocol::Topic::kForces, protocol::Topic::kStatus};
  const dds_entity_t waitset = dds_create_waitset(pp);
  if (waitset < 0) return dds_error("dds_create_waitset", waitset);
  for (std::size_t i = 0; i < topics.size(); ++i) {
    const auto qos = protocol::topic_qos(topics[i]);
    const dds_entity_t topic =
        dds_create_topic(pp, protocol::topic_descriptor(topics[i]), protocol::topic_name(topics[i]),
                         qos.get(), nullptr);
    if (topic < 0) return dds_error("dds_create_topic", topic);
    dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, kRecorderDepth);
    readers[i] = dds_create_reader(subscriber, topic, qos.get(), nullptr);
    if (readers[i] < 0) return dds_error("dds_create_reader", readers[i]);
    const dds_entity_t cond = dds_create_readcondition(readers[i], DDS_ANY_STATE);
    if (cond < 0) return dds_error("dds_create_readcondition", cond);
    if (const dds_return_t rc = dds_waitset_attach(waitset, cond, static_cast<dds_attach_t>(i));
        rc < 0)
      return dds_error("dds_waitset_attach", rc);
  }

  RecordingWriter writer;
  if (Status st = writer.open(options.out, options.domain); !st) return st.error();
  RecordSummary summary;
  const auto start = Clock::now();
  const auto seconds = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };

  for (bool last = false; !last;) {
    // One more pass after the stop request takes what has arrived in the meantime.
    last =
        stop.load() || (options.duration.count() > 0 && Clock::now() - start >= options.duration);
    const dds_return_t w = dds_waitset_wait(waitset, nullptr, 0, last ? 0 : DDS_MSECS(50));
    if (w < 0) return dds_error("dds_waitset_wait", w);
    for (std::size_t i = 0; i < readers.size(); ++i) {
      Status st;
      dds_return_t loan_rc = 0;
      const dds_return_t n = protocol::take_all(
          readers[i],
          [&](std::span<void* const> samples, std::span<const dds_sample_info_t> infos) {
            const double t = seconds();
            for (std::size_t k = 0; k < samples.size() && st; ++k)
              st = write_sample(writer, summary, topics[i], samples[k], infos[k], t);
            return static_cast<bool>(st);
          },
          [&](dds_return_t rc) {
            loan_rc = rc;
            return rc >= 0;
          });
      if (n < 0) return dds_error("dds_take", n);
      if (loan_rc < 0) return dds_error("dds_return_loan", loan_rc);
      if (!st) return st.error();
    }
    if (Status st = writer.flush(); !st) return st.error();
  }
  if (Status st = writer.close(); !st) return st.error();
  return summary;
}

}  // namespace tc::replay
