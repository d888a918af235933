// tetcollided's Prometheus metrics (config key metrics.listen, docs/DEPLOYMENT.md
// "Metrics"): the process figures read from /proc/self and glibc's heap figures at each
// scrape, and per scene the counters, gauges and histograms the scene's runner updates
// once per frame (no lock but prometheus-cpp's own: atomic counters and gauges, one
// uncontended mutex per histogram observation). Rejections are counted where every one
// of them goes, the ServiceStatus topic (CountingOutbox); ownership of a scene's answers
// is reported by the service's FrameStats reader (answer_owner). prometheus-cpp serves
// GET /metrics from its own thread.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>

#include "config.hpp"
#include "core/common/result.hpp"
#include "outbox.hpp"

namespace prometheus {
class Counter;
class Gauge;
class Histogram;
}  // namespace prometheus

namespace tc::daemon {

/// The registry, the HTTP server and the per-scene bookkeeping (metrics.cpp), shared by
/// Metrics and every SceneMetrics so that neither outlives it.
struct MetricsState;

/// One scene's series, held by the scene's SceneRunner (which runs one job at a time).
/// The series leave /metrics when the last holder lets go (the scene closed); a scene
/// opened again starts its counters from zero, which Prometheus' rate() treats as a reset.
class SceneMetrics {
 public:
  ~SceneMetrics();
  SceneMetrics(const SceneMetrics&) = delete;
  SceneMetrics& operator=(const SceneMetrics&) = delete;

  /// One computed frame: counted, its compute time and its latency (first state
  /// received -> answers written) observed, the scene's objects and contacts set.
  /// `dropped_so_far`: the scene's frames superseded before they ran, as the scheduler
  /// counts them (FrameStats.dropped_frames); the increase since the last call is added.
  void frame_done(double compute_s, double latency_s, std::size_t objects, std::uint64_t contacts,
                  std::uint64_t dropped_so_far);

  /// The scene's registered objects changed (registration or removal).
  void set_objects(std::size_t objects);

 private:
  friend class Metrics;
  friend struct MetricsState;
  struct Series;
  SceneMetrics(std::shared_ptr<MetricsState> state, std::string scene,
               std::unique_ptr<Series> series);

  std::shared_ptr<MetricsState> state_;
  std::string scene_;
  std::unique_ptr<Series> series_;
  std::uint64_t dropped_seen_ = 0;
};

class Metrics {
 public:
  /// The series, without an HTTP server (listen() starts it).
  Metrics();
  ~Metrics();
  Metrics(const Metrics&) = delete;
  Metrics& operator=(const Metrics&) = delete;

  /// Serves GET /metrics on `address` (one prometheus-cpp thread). The error names the
  /// key metrics.listen and the address.
  Status listen(const ListenAddress& address);
  /// The port listen() bound (its port 0 gives any free one); 0 before.
  [[nodiscard]] int port() const;

  /// The text GET /metrics answers (the Prometheus text format 0.0.4).
  [[nodiscard]] std::string text() const;

  /// The series of `scene`, created on the first call; every holder shares them.
  std::shared_ptr<SceneMetrics> scene(const std::string& scene);

  /// A state the service rejected with `code` (STATUS_*), by scene and code.
  void rejected_state(std::string_view scene, std::int32_t code);
  /// A topology the service rejected with `code`.
  void rejected_topology(std::string_view scene, std::int32_t code);

  /// The answers of `scene` that clients take (EXCLUSIVE ownership) now come from the
  /// FrameStats writer `writer` (a DDS instance handle); `own` when it is this daemon's.
  /// A change of writer after the first is counted as an ownership change (a failover or
  /// a take-over). Scenes this daemon does not serve are ignored.
  void answer_owner(std::string_view scene, std::uint64_t writer, bool own);

  /// Where tetcollide_dds_write_errors_total is read at each scrape.
  void set_write_errors(std::function<std::uint64_t()> read);

 private:
  std::shared_ptr<MetricsState> state_;
};

/// An Outbox that forwards everything to `inner` and counts the rejections among the
/// status messages (kError with an object: of a state when it names a frame, of a
/// topology otherwise) in `metrics`.
class CountingOutbox final : public Outbox {
 public:
  CountingOutbox(Outbox& inner, Metrics& metrics) : inner_(inner), metrics_(metrics) {}
  void publish_forces(const ForcesMessage& message) override { inner_.publish_forces(message); }
  void publish_stats(const StatsMessage& message) override { inner_.publish_stats(message); }
  void publish_status(const StatusMessage& message) override;

 private:
  Outbox& inner_;
  Metrics& metrics_;
};

/// Live heap bytes as glibc counts them (mallinfo2: uordblks + hblkhd, every arena; in a
/// sanitizer build, as its allocator counts them): what the program holds, not what the
/// allocator keeps from the OS.
std::uint64_t heap_in_use_bytes();

}  // namespace tc::daemon
