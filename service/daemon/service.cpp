#include "service.hpp"

#include <dds/dds.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <mutex>
#include <span>
#include <vector>

#include "dds_outbox.hpp"
#include "metrics.hpp"
#include "protocol.hpp"
#include "router.hpp"
#include "samples.hpp"
#include "scheduler.hpp"
#include "systemd_notify.hpp"
#include "take_all.hpp"

namespace tc::daemon {
namespace {

Error dds_failure(const std::string& call, dds_return_t rc) {
  return Error{ErrorCode::kIo, call + ": " + protocol::dds_error(rc)};
}

/// Logs a failed dds_return_loan and goes on taking.
bool log_loan_failure(const char* topic, dds_return_t rc) {
  if (rc < 0) spdlog::error("dds_return_loan({}): {}", topic, protocol::dds_error(rc));
  return true;
}

}  // namespace

std::string default_service_id() {
  std::array<char, 256> host{};
  if (gethostname(host.data(), host.size() - 1) != 0) host[0] = '\0';
  return "tetcollided-" + std::string(host.data()) + "-" + std::to_string(getpid());
}

/// ", shards <pattern> <strength>, ..." for the ready line; "" without shard strengths.
std::string shard_strengths_text(const DaemonConfig& c) {
  std::string out;
  for (const auto& [pattern, strength] : c.shard_strengths)
    out += (out.empty() ? ", shards " : ", ") + pattern + " " + std::to_string(strength);
  return out;
}

struct Service::Impl {
  explicit Impl(DaemonConfig c)
      : config(std::move(c)),
        outbox(config.service_id.empty() ? default_service_id() : config.service_id, config) {}

  DaemonConfig config;
  DdsOutbox outbox;
  /// With metrics.listen: the series, and the outbox that counts the rejections on the
  /// way to `outbox`. `publish_to` is what the router and the runners publish to.
  std::unique_ptr<Metrics> metrics;
  std::unique_ptr<CountingOutbox> counting;
  Outbox* publish_to = &outbox;
  IncompatibleQosMonitor qos_monitor;
  std::unique_ptr<Scheduler> scheduler;
  std::unique_ptr<Router> router;

  dds_entity_t domain = 0;
  dds_entity_t participant = 0;
  dds_entity_t topology_reader = 0;
  dds_entity_t state_reader = 0;
  /// With metrics: FrameStats as clients get them (EXCLUSIVE ownership), to see whose
  /// answers of each scene they take.
  dds_entity_t stats_reader = 0;
  dds_entity_t stats_cond = 0;
  dds_entity_t waitset = 0;
  dds_entity_t wakeup = 0;  // guard condition: stop requests and worker results

  std::atomic<bool> stopping{false};
  std::mutex inbox_mutex;
  std::vector<TopologyResult> inbox;

  Status create_reader(dds_entity_t subscriber, protocol::Topic topic, dds_entity_t& out) {
    const auto qos = protocol::topic_qos(topic);
    const dds_entity_t t = dds_create_topic(participant, protocol::topic_descriptor(topic),
                                            protocol::topic_name(topic), qos.get(), nullptr);
    if (t < 0)
      return dds_failure(std::string("dds_create_topic(") + protocol::topic_name(topic) + ")", t);
    out = dds_create_reader(subscriber, t, qos.get(), nullptr);
    if (out < 0)
      return dds_failure(std::string("dds_create_reader(") + protocol::topic_name(topic) + ")",
                         out);
    return {};
  }

  Status attach(dds_entity_t entity, const char* what) {
    if (const dds_return_t rc = dds_waitset_attach(waitset, entity, entity); rc < 0)
      return dds_failure(std::string("dds_waitset_attach(") + what + ")", rc);
    return {};
  }

  void wake() {
    if (const dds_return_t rc = dds_set_guardcondition(wakeup, true); rc < 0)
      spdlog::error("dds_set_guardcondition: {}", protocol::dds_error(rc));
  }

  void post_result(TopologyResult r) {
    {
      std::lock_guard lock(inbox_mutex);
      inbox.push_back(std::move(r));
    }
    wake();
  }

  /// Takes every available topology sample. Returns false on a DDS error.
  bool take_topologies(Clock::time_point now) {
    const dds_return_t n = protocol::take_all(
        topology_reader,
        [&](std::span<void* const> samples, std::span<const dds_sample_info_t> infos) {
          for (std::size_t i = 0; i < samples.size(); ++i) {
            const auto* s = static_cast<const tetcollide_MeshTopology*>(samples[i]);
            const dds_sample_info_t& info = infos[i];
            if (info.valid_data) {
              try {
                TopologyView view = view_of(*s);
                view.source_timestamp = info.source_timestamp;
                router->on_topology(view, now);
              } catch (const std::exception& e) {  // allocation failure on a huge mesh
                spdlog::error("{}/{}: topology not processed: {}", protocol::bounded_view(s->scene),
                              protocol::bounded_view(s->object), e.what());
              }
            }
            if (info.instance_state != DDS_IST_ALIVE)
              router->on_topology_gone(protocol::bounded_view(s->scene),
                                       protocol::bounded_view(s->object));
          }
          return true;
        },
        [](dds_return_t rc) { return log_loan_failure("MeshTopology", rc); });
    if (n < 0) spdlog::error("dds_take(MeshTopology): {}", protocol::dds_error(n));
    return n >= 0;
  }

  bool take_states(Clock::time_point now) {
    const dds_return_t n = protocol::take_all(
        state_reader,
        [&](std::span<void* const> samples, std::span<const dds_sample_info_t> infos) {
          for (std::size_t i = 0; i < samples.size(); ++i) {
            if (!infos[i].valid_data) continue;
            try {
              router->on_state(view_of(*static_cast<const tetcollide_MeshState*>(samples[i])), now);
            } catch (const std::exception& e) {
              spdlog::error("state not processed: {}", e.what());
            }
          }
          return true;
        },
        [](dds_return_t rc) { return log_loan_failure("MeshState", rc); });
    if (n < 0) spdlog::error("dds_take(MeshState): {}", protocol::dds_error(n));
    return n >= 0;
  }

  /// Takes the FrameStats samples: each came from the writer that owns its scene's
  /// answers at that moment (EXCLUSIVE ownership), this daemon's or another's.
  void take_stats() {
    const dds_return_t n = protocol::take_all(
        stats_reader,
        [&](std::span<void* const> samples, std::span<const dds_sample_info_t> infos) {
          for (std::size_t i = 0; i < samples.size(); ++i) {
            if (!infos[i].valid_data) continue;
            const auto* st = static_cast<const tetcollide_FrameStats*>(samples[i]);
            metrics->answer_owner(protocol::bounded_view(st->scene), infos[i].publication_handle,
                                  outbox.own_stats_writer(infos[i].publication_handle));
          }
          return true;
        },
        [](dds_return_t rc) { return log_loan_failure("FrameStats", rc); });
    if (n < 0) spdlog::error("dds_take(FrameStats): {}", protocol::dds_error(n));
  }
};

Service::Service(DaemonConfig config) : impl_(std::make_unique<Impl>(std::move(config))) {}

Service::~Service() {
  if (impl_->scheduler) impl_->scheduler->shutdown(std::chrono::seconds(30));
  impl_->scheduler.reset();
  if (impl_->participant > 0) {
    if (const dds_return_t rc = dds_delete(impl_->participant); rc < 0)
      spdlog::error("dds_delete(participant): {}", protocol::dds_error(rc));
  }
  if (impl_->domain > 0) {
    if (const dds_return_t rc = dds_delete(impl_->domain); rc < 0)
      spdlog::error("dds_delete(domain): {}", protocol::dds_error(rc));
  }
}

Status Service::start() {
  Impl& s = *impl_;
  const DaemonConfig& c = s.config;
  if (!c.cyclonedds_config.empty()) {
    s.domain = dds_create_domain(c.domain, c.cyclonedds_config.c_str());
    if (s.domain < 0) return dds_failure("dds_create_domain(dds.cyclonedds_config)", s.domain);
  }
  s.participant = dds_create_participant(c.domain, nullptr, nullptr);
  if (s.participant < 0)
    return dds_failure("dds_create_participant(domain " + std::to_string(c.domain) + ")",
                       s.participant);
  if (Status st = s.outbox.create(s.participant); !st) return st;
  s.outbox.set_state(ServiceState::kStarting, "starting");
  if (const std::size_t leak = test_leak_bytes_per_removal(); leak > 0)
    spdlog::warn(
        "TETCOLLIDED_TEST_LEAK_BYTES_PER_REMOVAL={}: this daemon keeps {} bytes per object "
        "removal on purpose (a test-only switch for the soak, docs/RELIABILITY.md); never set "
        "it in production",
        leak, leak);
  if (!c.metrics_listen.empty()) {
    auto address = parse_listen_address(c.metrics_listen);
    if (!address) return address.error();
    s.metrics = std::make_unique<Metrics>();
    s.metrics->set_write_errors([&s] { return s.outbox.write_errors(); });
    if (Status st = s.metrics->listen(*address); !st) return st;
    s.counting = std::make_unique<CountingOutbox>(s.outbox, *s.metrics);
    s.publish_to = s.counting.get();
    const std::string url =
        "http://" + address->host + ":" + std::to_string(s.metrics->port()) + "/metrics";
    if (address->loopback)
      spdlog::info("metrics: serving {}", url);
    else
      spdlog::warn(
          "metrics: serving {} on an address that is not loopback (metrics.listen = {}): every "
          "host that reaches it can read the scene names and figures, without authentication; "
          "restrict it with a firewall or use 127.0.0.1",
          url, c.metrics_listen);
  }

  s.scheduler =
      std::make_unique<Scheduler>(c.threads, c.max_queued_frames, [&s](const std::string& scene) {
        return std::make_unique<SceneRunner>(
            scene, s.config.pipeline, *s.publish_to,
            [&s](TopologyResult r) { s.post_result(std::move(r)); },
            s.config.timing_summary_period_s,
            s.metrics ? s.metrics->scene(scene) : std::shared_ptr<SceneMetrics>());
      });
  s.router = std::make_unique<Router>(s.config, *s.publish_to, *s.scheduler);

  const auto pqos = protocol::partition_qos(c.partition);
  const dds_entity_t subscriber = dds_create_subscriber(s.participant, pqos.get(), nullptr);
  if (subscriber < 0) return dds_failure("dds_create_subscriber", subscriber);
  if (Status st = s.create_reader(subscriber, protocol::Topic::kTopology, s.topology_reader); !st)
    return st;
  if (Status st = s.create_reader(subscriber, protocol::Topic::kState, s.state_reader); !st)
    return st;
  s.qos_monitor.add_reader(s.topology_reader, protocol::Topic::kTopology);
  s.qos_monitor.add_reader(s.state_reader, protocol::Topic::kState);
  s.outbox.watch(s.qos_monitor);

  s.waitset = dds_create_waitset(s.participant);
  if (s.waitset < 0) return dds_failure("dds_create_waitset", s.waitset);
  s.wakeup = dds_create_guardcondition(s.participant);
  if (s.wakeup < 0) return dds_failure("dds_create_guardcondition", s.wakeup);
  const dds_entity_t topo_cond = dds_create_readcondition(s.topology_reader, DDS_ANY_STATE);
  if (topo_cond < 0) return dds_failure("dds_create_readcondition(MeshTopology)", topo_cond);
  const dds_entity_t state_cond = dds_create_readcondition(s.state_reader, DDS_ANY_STATE);
  if (state_cond < 0) return dds_failure("dds_create_readcondition(MeshState)", state_cond);
  if (Status st = s.attach(s.wakeup, "guard condition"); !st) return st;
  if (Status st = s.attach(topo_cond, "MeshTopology"); !st) return st;
  if (Status st = s.attach(state_cond, "MeshState"); !st) return st;
  if (s.metrics) {
    if (Status st = s.create_reader(subscriber, protocol::Topic::kStats, s.stats_reader); !st)
      return st;
    s.stats_cond = dds_create_readcondition(s.stats_reader, DDS_ANY_STATE);
    if (s.stats_cond < 0) return dds_failure("dds_create_readcondition(FrameStats)", s.stats_cond);
    if (Status st = s.attach(s.stats_cond, "FrameStats"); !st) return st;
  }
  return {};
}

Status Service::run() {
  Impl& s = *impl_;
  if (s.router == nullptr) return Error{ErrorCode::kInvalidArgument, "Service::run before start"};
  const DaemonConfig& c = s.config;
  // systemd (Type=notify) learns readiness at the same moment as DDS readers (the READY
  // sample) and the log; outside systemd the notifier does nothing.
  SystemdNotifier notifier(Clock::now());
  s.outbox.set_state(ServiceState::kReady, "ready");
  spdlog::info(
      "tetcollided ready (service {}, domain {}, partition '{}', scenes {}, ownership strength "
      "{}{}, "
      "answer lease {} ms)",
      s.outbox.service_id(), c.domain, c.partition,
      c.scenes.empty() ? std::string("all") : fmt::format("{}", fmt::join(c.scenes, ",")),
      c.ownership_strength, shard_strengths_text(c), c.answer_lease_ms);
  notifier.ready("ready: " + status_line(0, 0, 0.0));

  const auto heartbeat_period =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(c.status_period_s));
  auto last_heartbeat = Clock::now();
  auto next_heartbeat = last_heartbeat + heartbeat_period;
  std::uint64_t frames_at_last_heartbeat = 0;
  Status result;
  std::array<dds_attach_t, 4> triggered{};
  while (!s.stopping.load()) {
    auto now = Clock::now();
    Clock::time_point until = next_heartbeat;
    if (const auto d = s.router->next_deadline(); d && *d < until) until = *d;
    if (const auto w = notifier.next_watchdog(); w && *w < until) until = *w;
    const dds_duration_t timeout =
        until <= now ? 0
                     : std::chrono::duration_cast<std::chrono::nanoseconds>(until - now).count();
    const dds_return_t n = dds_waitset_wait(s.waitset, triggered.data(), triggered.size(), timeout);
    if (n < 0) {
      result = dds_failure("dds_waitset_wait", n);
      spdlog::error("{}", result.error().message);
      break;
    }
    if (s.stopping.load()) break;
    if (const dds_return_t rc = dds_set_guardcondition(s.wakeup, false); rc < 0)
      spdlog::error("dds_set_guardcondition: {}", protocol::dds_error(rc));
    now = Clock::now();
    std::vector<TopologyResult> results;
    {
      std::lock_guard lock(s.inbox_mutex);
      results.swap(s.inbox);
    }
    for (const auto& r : results) s.router->on_topology_result(r, now);
    // Topologies first: a state whose topology arrived in the same batch is then known.
    if (!s.take_topologies(now) || !s.take_states(now)) {
      result = Error{ErrorCode::kIo, "reading from DDS failed (see the log)"};
      break;
    }
    const auto fired = triggered.begin() + std::min<std::ptrdiff_t>(n, triggered.size());
    if (s.stats_cond > 0 && std::any_of(triggered.begin(), fired, [&](dds_attach_t a) {
          return a == static_cast<dds_attach_t>(s.stats_cond);
        }))
      s.take_stats();
    now = Clock::now();
    s.router->tick(now);
    // This loop is the one thread that must never stall: it pings the watchdog.
    notifier.watchdog(now);
    if (now >= next_heartbeat) {
      StatusMessage hb;
      hb.kind = StatusKind::kHeartbeat;
      hb.message = std::to_string(s.router->scene_count()) + " scenes";
      s.outbox.publish_status(hb);
      // Clients whose QoS keeps DDS from matching them hear nothing else: tell them here.
      for (auto& text : s.qos_monitor.poll()) {
        spdlog::warn("{}", text);
        StatusMessage msg;
        msg.kind = StatusKind::kError;
        msg.code = tetcollide_STATUS_INVALID_ARGUMENT;
        msg.message = std::move(text);
        s.outbox.publish_status(msg);
      }
      const std::uint64_t frames = s.router->dispatched_frames();
      const double seconds = std::chrono::duration<double>(now - last_heartbeat).count();
      notifier.status(status_line(
          s.router->scene_count(), s.router->object_count(),
          seconds > 0.0 ? static_cast<double>(frames - frames_at_last_heartbeat) / seconds : 0.0));
      frames_at_last_heartbeat = frames;
      last_heartbeat = now;
      next_heartbeat = now + heartbeat_period;
    }
  }
  s.outbox.set_state(ServiceState::kStopping, "stopping");
  spdlog::info("tetcollided stopping");
  notifier.stopping("stopping");
  if (!s.scheduler->shutdown(std::chrono::seconds(10)))
    spdlog::warn("scene jobs still running after 10 s; waiting for them");
  return result;
}

void Service::stop() {
  impl_->stopping.store(true);
  if (impl_->wakeup > 0) impl_->wake();
}

}  // namespace tc::daemon
