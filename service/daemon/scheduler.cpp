#include "scheduler.hpp"

#include <spdlog/spdlog.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/task_arena.h>

#include <atomic>
#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>

namespace tc::daemon {

struct Scheduler::Impl {
  struct Slot {
    std::mutex mutex;
    std::deque<SceneJob> jobs;
    bool running = false;
    bool closing = false;
    std::uint64_t dropped = 0;
    std::unique_ptr<SceneRunner> runner;
  };

  Impl(int threads, int max_queued, RunnerFactory f)
      : concurrency(threads > 0 ? threads : tbb::info::default_concurrency()),
        // No application thread joins the arena: all `concurrency` threads are TBB
        // workers, so the global worker limit must allow that many.
        workers(tbb::global_control::max_allowed_parallelism,
                static_cast<std::size_t>(concurrency) + 1),
        arena(concurrency, 0),
        max_queued_frames(static_cast<std::size_t>(max_queued)),
        factory(std::move(f)) {}

  int concurrency;
  tbb::global_control workers;
  tbb::task_arena arena;
  std::size_t max_queued_frames;
  RunnerFactory factory;

  // Lock order: slots_mutex, then a Slot::mutex, then idle_mutex; never the reverse.
  std::mutex slots_mutex;
  std::map<std::string, std::shared_ptr<Slot>> slots;
  bool stopping = false;
  std::atomic<std::uint64_t> dropped_total{0};

  std::mutex idle_mutex;
  std::condition_variable idle_cv;
  int in_flight = 0;  // scheduled drain tasks

  void schedule(const std::string& scene, const std::shared_ptr<Slot>& slot) {
    {
      std::lock_guard lock(idle_mutex);
      ++in_flight;
    }
    arena.enqueue([this, scene, slot] { drain_one(scene, slot); });
  }

  void finished() {
    std::lock_guard lock(idle_mutex);
    if (--in_flight == 0) idle_cv.notify_all();
  }

  /// Runs the oldest job of a slot, then reschedules the slot if more are waiting (one
  /// job per task keeps scenes fair when there are fewer threads than busy scenes).
  void drain_one(const std::string& scene, const std::shared_ptr<Slot>& slot) {
    SceneJob job;
    {
      std::unique_lock lock(slot->mutex);
      if (slot->jobs.empty()) {  // emptied by shutdown()
        slot->running = false;
        lock.unlock();
        finished();
        return;
      }
      job = std::move(slot->jobs.front());
      slot->jobs.pop_front();
      if (auto* frame = std::get_if<FrameJob>(&job)) frame->dropped_frames = slot->dropped;
    }
    try {
      if (!slot->runner) slot->runner = factory(scene);
      slot->runner->run(job);
    } catch (const std::exception& e) {
      spdlog::error("{}: scene job failed: {}", scene, e.what());
    }
    bool again = false;
    bool release = false;
    {
      std::lock_guard slots_lock(slots_mutex);
      std::lock_guard lock(slot->mutex);
      if (!slot->jobs.empty()) {
        again = true;
      } else {
        slot->running = false;
        if (slot->closing) {
          release = true;
          const auto it = slots.find(scene);
          if (it != slots.end() && it->second == slot) slots.erase(it);
        }
      }
    }
    if (release) slot->runner.reset();  // frees the scene's pipeline
    if (again) {
      {
        std::lock_guard lock(idle_mutex);
        ++in_flight;
      }
      arena.enqueue([this, scene, slot] { drain_one(scene, slot); });
    }
    finished();
  }
};

Scheduler::Scheduler(int threads, int max_queued_frames, RunnerFactory factory)
    : impl_(std::make_unique<Impl>(threads, max_queued_frames, std::move(factory))) {}

Scheduler::~Scheduler() {
  // Running jobs reference this object: wait for them however long they take.
  while (!shutdown(std::chrono::seconds(10)))
    spdlog::warn("scheduler: still waiting for running scene jobs to finish");
}

void Scheduler::post(const std::string& scene, SceneJob job) {
  std::shared_ptr<Impl::Slot> slot;
  bool start = false;
  {
    std::lock_guard slots_lock(impl_->slots_mutex);
    if (impl_->stopping) return;
    auto& entry = impl_->slots[scene];
    if (!entry) entry = std::make_shared<Impl::Slot>();
    slot = entry;
    std::lock_guard lock(slot->mutex);
    slot->closing = false;
    if (std::holds_alternative<FrameJob>(job)) {
      std::size_t frames = 0;
      for (const auto& j : slot->jobs) frames += std::holds_alternative<FrameJob>(j) ? 1 : 0;
      if (frames >= impl_->max_queued_frames) {
        const auto oldest =
            std::find_if(slot->jobs.begin(), slot->jobs.end(),
                         [](const SceneJob& j) { return std::holds_alternative<FrameJob>(j); });
        spdlog::debug("{}: frame {} dropped (superseded while the scene was busy)", scene,
                      std::get<FrameJob>(*oldest).frame);
        slot->jobs.erase(oldest);
        ++slot->dropped;
        ++impl_->dropped_total;
      }
    }
    slot->jobs.push_back(std::move(job));
    if (!slot->running) {
      slot->running = true;
      start = true;
    }
  }
  if (start) impl_->schedule(scene, slot);
}

void Scheduler::close_scene(const std::string& scene) {
  std::lock_guard slots_lock(impl_->slots_mutex);
  const auto it = impl_->slots.find(scene);
  if (it == impl_->slots.end()) return;
  const auto slot = it->second;
  std::lock_guard lock(slot->mutex);
  slot->closing = true;
  if (!slot->running && slot->jobs.empty()) {
    impl_->slots.erase(it);  // the last reference may be a finished drain: runner goes now
  }
}

bool Scheduler::shutdown(std::chrono::milliseconds timeout) {
  {
    std::lock_guard slots_lock(impl_->slots_mutex);
    impl_->stopping = true;
    for (auto& [name, slot] : impl_->slots) {
      std::lock_guard lock(slot->mutex);
      slot->jobs.clear();
    }
  }
  bool idle = false;
  {
    std::unique_lock lock(impl_->idle_mutex);
    idle = impl_->idle_cv.wait_for(lock, timeout, [this] { return impl_->in_flight == 0; });
  }
  if (idle) {
    std::lock_guard slots_lock(impl_->slots_mutex);
    impl_->slots.clear();
  }
  return idle;
}

std::size_t Scheduler::active_scenes() const {
  std::lock_guard lock(impl_->slots_mutex);
  return impl_->slots.size();
}

std::uint64_t Scheduler::dropped_frames() const {
  return impl_->dropped_total.load();
}

}  // namespace tc::daemon
