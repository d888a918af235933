#include "metrics.hpp"

#include <dirent.h>
#include <malloc.h>
#include <sys/resource.h>
#include <unistd.h>

#include <prometheus/collectable.h>
#include <prometheus/counter.h>
#include <prometheus/exposer.h>
#include <prometheus/gauge.h>
#include <prometheus/histogram.h>
#include <prometheus/registry.h>
#include <prometheus/text_serializer.h>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <utility>
#include <vector>

#include "protocol.hpp"
#include "tetcollide.h"

// A sanitizer replaces malloc: glibc's mallinfo2() then sees none of the heap, and the
// sanitizer's allocator says what it holds instead.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define TC_SANITIZER_ALLOCATOR 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define TC_SANITIZER_ALLOCATOR 1
#endif
#endif
#ifdef TC_SANITIZER_ALLOCATOR
#include <sanitizer/allocator_interface.h>
#endif

namespace tc::daemon {
namespace {

/// The heap the daemon holds: bytes in use (live allocations) and bytes the allocator
/// holds from the OS (in use plus free chunks not returned).
struct HeapFigures {
  double in_use = 0.0;
  double held = 0.0;
};

HeapFigures heap_figures() {
#ifdef TC_SANITIZER_ALLOCATOR
  return {static_cast<double>(__sanitizer_get_current_allocated_bytes()),
          static_cast<double>(__sanitizer_get_heap_size())};
#else
  const struct mallinfo2 heap = mallinfo2();  // (every arena)
  return {static_cast<double>(heap.uordblks + heap.hblkhd),
          static_cast<double>(heap.arena + heap.hblkhd)};
#endif
}

using prometheus::ClientMetric;
using prometheus::Counter;
using prometheus::Family;
using prometheus::Gauge;
using prometheus::Histogram;
using prometheus::MetricFamily;
using prometheus::MetricType;

/// Seconds; fit for frames of 0.1 ms (two small objects) to 100 ms and beyond (two
/// 329k-tet boxes take about 120 ms on 2 cores, docs/RELIABILITY.md "Load").
const Histogram::BucketBoundaries kSecondsBuckets{
    0.0001, 0.00025, 0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5};

/// Scenes that have rejections but no runner (states for a scene nobody registered in)
/// each get their own series up to this many; the rest count under scene="(other)".
constexpr std::size_t kMaxIdleScenes = 64;

/// Fields of /proc/self/stat after the command name (field 3 = state), as text.
std::vector<std::string> stat_fields() {
  std::ifstream in("/proc/self/stat");
  std::string all;
  std::getline(in, all);
  std::vector<std::string> fields{"", "", ""};  // 1-based, 1 and 2 (pid, comm) left out
  const auto close = all.rfind(')');
  if (close == std::string::npos) return {};
  std::istringstream rest(all.substr(close + 1));
  std::string field;
  while (rest >> field) fields.push_back(field);
  return fields;
}

double stat_number(const std::vector<std::string>& fields, std::size_t i) {
  return i < fields.size() ? std::strtod(fields[i].c_str(), nullptr) : 0.0;
}

/// Seconds since the epoch when this process started (boot time + stat field 22).
double process_start_time() {
  double boot = 0.0;
  std::ifstream in("/proc/stat");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("btime ", 0) == 0) boot = std::strtod(line.c_str() + 6, nullptr);
  return boot + stat_number(stat_fields(), 22) / static_cast<double>(sysconf(_SC_CLK_TCK));
}

/// Open file descriptors, the one this count opens left out.
int open_fds() {
  DIR* d = opendir("/proc/self/fd");
  if (d == nullptr) return -1;
  const std::string own = std::to_string(dirfd(d));
  int n = 0;
  while (const dirent* e = readdir(d))
    if (e->d_name[0] != '.' && own != e->d_name) ++n;
  closedir(d);
  return n;
}

MetricFamily one_value(std::string name, std::string help, MetricType type, double value) {
  ClientMetric m;
  if (type == MetricType::Counter)
    m.counter.value = value;
  else
    m.gauge.value = value;
  return MetricFamily{std::move(name), std::move(help), type, {m}};
}

/// The process figures at each scrape (prometheus-cpp exports none by itself), with the
/// conventional names of the Prometheus client libraries, and glibc's heap figures.
class ProcessCollector final : public prometheus::Collectable {
 public:
  explicit ProcessCollector(std::function<std::uint64_t()>* write_errors, std::mutex* mutex)
      : start_time_(process_start_time()), write_errors_(write_errors), mutex_(mutex) {}

  std::vector<MetricFamily> Collect() const override {
    const auto f = stat_fields();
    const double ticks = static_cast<double>(sysconf(_SC_CLK_TCK));
    const double page = static_cast<double>(sysconf(_SC_PAGESIZE));
    rlimit files{};
    getrlimit(RLIMIT_NOFILE, &files);
    const HeapFigures heap = heap_figures();
    std::vector<MetricFamily> out;
    out.push_back(one_value("process_cpu_seconds_total",
                            "Total user and system CPU time spent in seconds.", MetricType::Counter,
                            (stat_number(f, 14) + stat_number(f, 15)) / ticks));
    out.push_back(one_value("process_resident_memory_bytes", "Resident memory size in bytes.",
                            MetricType::Gauge, stat_number(f, 24) * page));
    out.push_back(one_value("process_virtual_memory_bytes", "Virtual memory size in bytes.",
                            MetricType::Gauge, stat_number(f, 23)));
    out.push_back(one_value("process_start_time_seconds",
                            "Start time of the process since unix epoch in seconds.",
                            MetricType::Gauge, start_time_));
    out.push_back(one_value("process_open_fds", "Number of open file descriptors.",
                            MetricType::Gauge, open_fds()));
    out.push_back(one_value("process_max_fds", "Maximum number of open file descriptors.",
                            MetricType::Gauge, static_cast<double>(files.rlim_cur)));
    out.push_back(one_value("process_threads", "Number of OS threads in the process.",
                            MetricType::Gauge, stat_number(f, 20)));
    out.push_back(one_value(
        "tetcollide_heap_in_use_bytes",
        "Bytes of heap the daemon holds (glibc mallinfo2 uordblks + hblkhd, every arena); "
        "a leak shows here, the allocator's fragmentation does not.",
        MetricType::Gauge, heap.in_use));
    out.push_back(one_value("tetcollide_heap_held_bytes",
                            "Bytes the allocator holds from the OS (glibc mallinfo2 arena + "
                            "hblkhd): in use plus free chunks not returned.",
                            MetricType::Gauge, heap.held));
    std::uint64_t errors = 0;
    {
      std::lock_guard lock(*mutex_);
      if (*write_errors_) errors = (*write_errors_)();
    }
    out.push_back(one_value("tetcollide_dds_write_errors_total",
                            "DDS writes of answers, statistics or status that failed.",
                            MetricType::Counter, static_cast<double>(errors)));
    return out;
  }

 private:
  double start_time_;
  std::function<std::uint64_t()>* write_errors_;
  std::mutex* mutex_;
};

}  // namespace

struct SceneMetrics::Series {
  Counter& frames;
  Histogram& compute;
  Histogram& latency;
  Gauge& objects;
  Gauge& contacts;
  Counter& dropped;
  Gauge& owner;
  Counter& ownership_changes;
};

struct MetricsState {
  MetricsState()
      : registry(std::make_shared<prometheus::Registry>()),
        frames(prometheus::BuildCounter()
                   .Name("tetcollide_frames_total")
                   .Help("Frames of the scene computed and answered.")
                   .Register(*registry)),
        compute(prometheus::BuildHistogram()
                    .Name("tetcollide_frame_compute_seconds")
                    .Help("Time the pipeline took for a frame of the scene (FrameStats "
                          "compute_ms).")
                    .Register(*registry)),
        latency(prometheus::BuildHistogram()
                    .Name("tetcollide_frame_latency_seconds")
                    .Help("First state of a frame received -> its answers written.")
                    .Register(*registry)),
        objects(prometheus::BuildGauge()
                    .Name("tetcollide_objects")
                    .Help("Objects registered in the scene.")
                    .Register(*registry)),
        contacts(prometheus::BuildGauge()
                     .Name("tetcollide_contacts")
                     .Help("Contacts found in the scene's latest frame.")
                     .Register(*registry)),
        dropped(prometheus::BuildCounter()
                    .Name("tetcollide_dropped_frames_total")
                    .Help("Frames of the scene superseded by a newer one before they ran "
                          "(never answered; newest wins).")
                    .Register(*registry)),
        owner(prometheus::BuildGauge()
                  .Name("tetcollide_answer_owner")
                  .Help("1 while clients take this daemon's answers for the scene (the "
                        "strongest live writer), 0 while they take another daemon's.")
                  .Register(*registry)),
        ownership_changes(prometheus::BuildCounter()
                              .Name("tetcollide_ownership_changes_total")
                              .Help("Times the daemon whose answers clients take for the "
                                    "scene changed (failovers and take-overs).")
                              .Register(*registry)),
        rejected_states(prometheus::BuildCounter()
                            .Name("tetcollide_rejected_states_total")
                            .Help("States the service rejected, by status code.")
                            .Register(*registry)),
        rejected_topologies(prometheus::BuildCounter()
                                .Name("tetcollide_rejected_topologies_total")
                                .Help("Topologies the service rejected, by status code.")
                                .Register(*registry)),
        process(std::make_shared<ProcessCollector>(&write_errors, &mutex)) {}

  std::shared_ptr<prometheus::Registry> registry;
  Family<Counter>& frames;
  Family<Histogram>& compute;
  Family<Histogram>& latency;
  Family<Gauge>& objects;
  Family<Gauge>& contacts;
  Family<Counter>& dropped;
  Family<Gauge>& owner;
  Family<Counter>& ownership_changes;
  Family<Counter>& rejected_states;
  Family<Counter>& rejected_topologies;

  std::mutex mutex;  ///< guards what follows
  std::function<std::uint64_t()> write_errors;
  struct SceneEntry {
    std::weak_ptr<SceneMetrics> live;
    const SceneMetrics::Series* series = nullptr;                ///< of `live`, while it exists
    std::map<std::pair<bool, std::int32_t>, Counter*> rejected;  ///< (topology?, code)
    std::uint64_t owner_writer = 0;
  };
  std::map<std::string, SceneEntry, std::less<>> scenes;

  std::shared_ptr<ProcessCollector> process;
  std::unique_ptr<prometheus::Exposer> exposer;  ///< last: stops serving first

  void count_rejected(std::string_view scene, bool topology, std::int32_t code) {
    std::lock_guard lock(mutex);
    auto it = scenes.find(scene);
    if (it == scenes.end()) {
      std::size_t idle = 0;
      for (const auto& [name, entry] : scenes) idle += entry.series == nullptr ? 1 : 0;
      it = scenes.emplace(idle < kMaxIdleScenes ? std::string(scene) : "(other)", SceneEntry{})
               .first;
    }
    Counter*& counter = it->second.rejected[{topology, code}];
    if (counter == nullptr)
      counter =
          &(topology ? rejected_topologies : rejected_states)
               .Add({{"scene", it->first}, {"code", std::string(protocol::status_name(code))}});
    counter->Increment();
  }
};

SceneMetrics::SceneMetrics(std::shared_ptr<MetricsState> state, std::string scene,
                           std::unique_ptr<Series> series)
    : state_(std::move(state)), scene_(std::move(scene)), series_(std::move(series)) {}

SceneMetrics::~SceneMetrics() {
  MetricsState& s = *state_;
  std::lock_guard lock(s.mutex);
  const auto it = s.scenes.find(scene_);
  // A runner of the same scene started since (the scene opened again while this one was
  // being let go) shares these series: they stay.
  if (it == s.scenes.end() || it->second.series != series_.get()) return;
  s.frames.Remove(&series_->frames);
  s.compute.Remove(&series_->compute);
  s.latency.Remove(&series_->latency);
  s.objects.Remove(&series_->objects);
  s.contacts.Remove(&series_->contacts);
  s.dropped.Remove(&series_->dropped);
  s.owner.Remove(&series_->owner);
  s.ownership_changes.Remove(&series_->ownership_changes);
  for (const auto& [key, counter] : it->second.rejected)
    (key.first ? s.rejected_topologies : s.rejected_states).Remove(counter);
  s.scenes.erase(it);
}

void SceneMetrics::frame_done(double compute_s, double latency_s, std::size_t objects,
                              std::uint64_t contacts, std::uint64_t dropped_so_far) {
  series_->frames.Increment();
  series_->compute.Observe(compute_s);
  series_->latency.Observe(latency_s);
  series_->objects.Set(static_cast<double>(objects));
  series_->contacts.Set(static_cast<double>(contacts));
  if (dropped_so_far > dropped_seen_) {
    series_->dropped.Increment(static_cast<double>(dropped_so_far - dropped_seen_));
    dropped_seen_ = dropped_so_far;
  }
}

void SceneMetrics::set_objects(std::size_t objects) {
  series_->objects.Set(static_cast<double>(objects));
}

Metrics::Metrics() : state_(std::make_shared<MetricsState>()) {}

Metrics::~Metrics() {
  // Stop serving before the series go (the exposer's thread reads them).
  std::unique_ptr<prometheus::Exposer> exposer;
  {
    std::lock_guard lock(state_->mutex);
    exposer = std::move(state_->exposer);
  }
  exposer.reset();
}

Status Metrics::listen(const ListenAddress& address) {
  const std::string where = address.host + ":" + std::to_string(address.port);
  try {
    auto exposer = std::make_unique<prometheus::Exposer>(where, 1);
    exposer->RegisterCollectable(state_->registry);
    exposer->RegisterCollectable(state_->process);
    std::lock_guard lock(state_->mutex);
    state_->exposer = std::move(exposer);
  } catch (const std::exception& e) {
    return Error{ErrorCode::kIo, "metrics.listen: cannot serve on " + where + ": " + e.what() +
                                     " (port in use, or an address of no interface here?)"};
  }
  return {};
}

int Metrics::port() const {
  std::lock_guard lock(state_->mutex);
  if (!state_->exposer) return 0;
  const auto ports = state_->exposer->GetListeningPorts();
  return ports.empty() ? 0 : ports.front();
}

std::string Metrics::text() const {
  auto families = state_->registry->Collect();
  for (auto& f : state_->process->Collect()) families.push_back(std::move(f));
  return prometheus::TextSerializer().Serialize(families);
}

std::shared_ptr<SceneMetrics> Metrics::scene(const std::string& scene) {
  MetricsState& s = *state_;
  std::lock_guard lock(s.mutex);
  MetricsState::SceneEntry& entry = s.scenes[scene];
  if (auto live = entry.live.lock()) return live;
  const prometheus::Labels labels{{"scene", scene}};
  auto series = std::make_unique<SceneMetrics::Series>(SceneMetrics::Series{
      s.frames.Add(labels), s.compute.Add(labels, kSecondsBuckets),
      s.latency.Add(labels, kSecondsBuckets), s.objects.Add(labels), s.contacts.Add(labels),
      s.dropped.Add(labels), s.owner.Add(labels), s.ownership_changes.Add(labels)});
  entry.series = series.get();
  entry.owner_writer = 0;
  std::shared_ptr<SceneMetrics> out(new SceneMetrics(state_, scene, std::move(series)));
  entry.live = out;
  return out;
}

void Metrics::rejected_state(std::string_view scene, std::int32_t code) {
  state_->count_rejected(scene, false, code);
}

void Metrics::rejected_topology(std::string_view scene, std::int32_t code) {
  state_->count_rejected(scene, true, code);
}

void Metrics::answer_owner(std::string_view scene, std::uint64_t writer, bool own) {
  MetricsState& s = *state_;
  std::lock_guard lock(s.mutex);
  const auto it = s.scenes.find(scene);
  if (it == s.scenes.end() || it->second.series == nullptr) return;
  MetricsState::SceneEntry& entry = it->second;
  if (entry.owner_writer != 0 && entry.owner_writer != writer)
    entry.series->ownership_changes.Increment();
  entry.owner_writer = writer;
  entry.series->owner.Set(own ? 1.0 : 0.0);
}

void Metrics::set_write_errors(std::function<std::uint64_t()> read) {
  std::lock_guard lock(state_->mutex);
  state_->write_errors = std::move(read);
}

void CountingOutbox::publish_status(const StatusMessage& m) {
  inner_.publish_status(m);
  if (m.kind != StatusKind::kError || m.object.empty()) return;
  if (m.frame >= 0)
    metrics_.rejected_state(m.scene, m.code);
  else
    metrics_.rejected_topology(m.scene, m.code);
}

std::uint64_t heap_in_use_bytes() {
  return static_cast<std::uint64_t>(heap_figures().in_use);
}

}  // namespace tc::daemon
