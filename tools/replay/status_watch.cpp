#include "status_watch.hpp"

#include <dds/dds.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <span>

#include "protocol.hpp"
#include "take_all.hpp"
#include "tetcollide.h"

namespace tc::replay {
namespace {

using Clock = std::chrono::steady_clock;
constexpr std::int32_t kWatchDepth = 4096;  // samples kept between two takes
constexpr std::size_t kErrorsKept = 3;      // per scene

Error dds_error(const std::string& call, dds_return_t rc) {
  return Error{ErrorCode::kIo, call + ": " + protocol::dds_error(rc)};
}

const char* state_name(tetcollide_ServiceState s) {
  switch (s) {
    case tetcollide_STATE_STARTING:
      return "starting";
    case tetcollide_STATE_READY:
      return "ready";
    case tetcollide_STATE_STOPPING:
      return "stopping";
  }
  return "unknown";
}

/// Nearest-rank percentile of an unsorted copy.
double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const auto k = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size())));
  return v[std::min(v.size() - 1, k == 0 ? 0 : k - 1)];
}

}  // namespace

struct StatusWatcher::Impl {
  dds_entity_t participant = 0;
  dds_entity_t status_reader = 0;
  dds_entity_t stats_reader = 0;
  dds_entity_t waitset = 0;
  std::map<std::string, ServiceView> services;  // kept across windows (--watch)
  ~Impl() {
    if (participant > 0) dds_delete(participant);
  }
};

Expected<StatusWatcher> StatusWatcher::create(std::uint32_t domain, const std::string& partition) {
  StatusWatcher w;
  w.impl_ = new Impl;
  Impl& s = *w.impl_;
  s.participant = dds_create_participant(domain, nullptr, nullptr);
  if (s.participant < 0) return dds_error("dds_create_participant", s.participant);
  const auto pqos = protocol::partition_qos(partition);
  const dds_entity_t subscriber = dds_create_subscriber(s.participant, pqos.get(), nullptr);
  if (subscriber < 0) return dds_error("dds_create_subscriber", subscriber);
  s.waitset = dds_create_waitset(s.participant);
  if (s.waitset < 0) return dds_error("dds_create_waitset", s.waitset);
  for (const protocol::Topic t : {protocol::Topic::kStatus, protocol::Topic::kStats}) {
    const auto qos = protocol::topic_qos(t);
    const dds_entity_t topic = dds_create_topic(s.participant, protocol::topic_descriptor(t),
                                                protocol::topic_name(t), qos.get(), nullptr);
    if (topic < 0) return dds_error("dds_create_topic", topic);
    dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, kWatchDepth);
    const dds_entity_t reader = dds_create_reader(subscriber, topic, qos.get(), nullptr);
    if (reader < 0) return dds_error("dds_create_reader", reader);
    const dds_entity_t cond = dds_create_readcondition(reader, DDS_ANY_STATE);
    if (cond < 0) return dds_error("dds_create_readcondition", cond);
    if (const dds_return_t rc = dds_waitset_attach(s.waitset, cond, 0); rc < 0)
      return dds_error("dds_waitset_attach", rc);
    (t == protocol::Topic::kStatus ? s.status_reader : s.stats_reader) = reader;
  }
  return w;
}

StatusWatcher::StatusWatcher(StatusWatcher&& o) noexcept : impl_(std::exchange(o.impl_, nullptr)) {}
StatusWatcher& StatusWatcher::operator=(StatusWatcher&& o) noexcept {
  std::swap(impl_, o.impl_);
  return *this;
}
StatusWatcher::~StatusWatcher() {
  delete impl_;
}

Expected<StatusSnapshot> StatusWatcher::listen(std::chrono::milliseconds window,
                                               const std::atomic<bool>& stop) {
  Impl& s = *impl_;
  struct SceneData {
    SceneView view;
    std::vector<double> compute_ms;
  };
  std::map<std::string, SceneData> scenes;
  const auto start = Clock::now();
  for (bool last = false; !last;) {
    last = stop.load() || Clock::now() - start >= window;
    const dds_return_t w = dds_waitset_wait(s.waitset, nullptr, 0, last ? 0 : DDS_MSECS(50));
    if (w < 0) return dds_error("dds_waitset_wait", w);
    dds_return_t loan_rc = 0;
    const auto on_loan = [&](dds_return_t rc) {
      loan_rc = rc;
      return rc >= 0;
    };
    dds_return_t n = protocol::take_all(
        s.status_reader,
        [&](std::span<void* const> samples, std::span<const dds_sample_info_t> infos) {
          for (std::size_t k = 0; k < samples.size(); ++k) {
            const auto* m = static_cast<const tetcollide_ServiceStatus*>(samples[k]);
            const std::string id(protocol::bounded_view(m->service_id));
            ServiceView& v = s.services[id];
            v.id = id;
            if (!infos[k].valid_data) {  // the instance lost its writer or was disposed
              v.alive = infos[k].instance_state == DDS_IST_ALIVE;
              continue;
            }
            v.alive = true;
            v.state = state_name(m->state);
            v.protocol_version = m->protocol_version;
            v.uptime_s = m->uptime_s;
            v.ownership_strength = m->ownership_strength;
            v.message = std::string(protocol::bounded_view(m->message));
            const std::string scene(protocol::bounded_view(m->scene));
            if (m->kind == tetcollide_KIND_ERROR && !scene.empty()) {
              SceneData& d = scenes[scene];
              d.view.scene = scene;
              const std::string object(protocol::bounded_view(m->object));
              d.view.errors.push_back((object.empty() ? "" : object + ": ") + v.message);
              if (d.view.errors.size() > kErrorsKept) d.view.errors.erase(d.view.errors.begin());
            }
          }
          return true;
        },
        on_loan);
    if (n < 0) return dds_error("dds_take(ServiceStatus)", n);
    if (loan_rc < 0) return dds_error("dds_return_loan", loan_rc);
    n = protocol::take_all(
        s.stats_reader,
        [&](std::span<void* const> samples, std::span<const dds_sample_info_t> infos) {
          for (std::size_t k = 0; k < samples.size(); ++k) {
            if (!infos[k].valid_data) continue;
            const auto* m = static_cast<const tetcollide_FrameStats*>(samples[k]);
            const std::string scene(protocol::bounded_view(m->scene));
            SceneData& d = scenes[scene];
            d.view.scene = scene;
            d.view.objects = m->objects;
            ++d.view.frames;
            d.compute_ms.push_back(m->compute_ms);
            d.view.contacts = m->contacts;
            d.view.rejected += m->rejected;
            d.view.dropped_frames = m->dropped_frames;
          }
          return true;
        },
        on_loan);
    if (n < 0) return dds_error("dds_take(FrameStats)", n);
    if (loan_rc < 0) return dds_error("dds_return_loan", loan_rc);
  }
  StatusSnapshot out;
  out.window_s = std::chrono::duration<double>(Clock::now() - start).count();
  for (const auto& [id, v] : s.services) out.services.push_back(v);
  for (auto& [name, d] : scenes) {
    d.view.frames_per_s =
        out.window_s > 0.0 ? static_cast<double>(d.view.frames) / out.window_s : 0.0;
    d.view.compute_ms_p50 = percentile(d.compute_ms, 0.50);
    d.view.compute_ms_p99 = percentile(d.compute_ms, 0.99);
    out.scenes.push_back(std::move(d.view));
  }
  return out;
}

}  // namespace tc::replay
