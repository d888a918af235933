#include "scene_runner.hpp"

#include <malloc.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <memory>
#include <mutex>

#include "samples.hpp"
#include "tetcollide.h"

namespace tc::daemon {
namespace {

/// A number as the messages print it (%g).
std::string number_text(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

/// Names with their stiffness, at most four then a count.
std::string names_text(const std::vector<std::pair<std::string, double>>& names) {
  std::string out;
  for (std::size_t i = 0; i < names.size() && i < 4; ++i)
    out += (i ? ", '" : "'") + names[i].first + "' (" + number_text(names[i].second) + ")";
  if (names.size() > 4) out += " and " + std::to_string(names.size() - 4) + " more";
  return out;
}

/// What the pair rule (the smaller stiffness) does to a newly registered object's pairs,
/// said once with its registration (docs/INTEGRATORS.md); empty when nothing is capped.
std::string caps_text(const Pipeline::StiffnessCaps& caps, double own) {
  std::string out;
  if (!caps.capped_by.empty())
    out = "pairs with " + names_text(caps.capped_by) +
          " use that smaller stiffness, below this object's " + number_text(own);
  if (!caps.caps.empty())
    out += (out.empty() ? "" : "; ") + std::string("this object's stiffness ") + number_text(own) +
           " caps its pairs with " + names_text(caps.caps);
  return out;
}

/// The 3x3 blocks as 9 row-major doubles each, into `rows` (reused).
std::span<const double> row_major(const std::vector<Eigen::Matrix3d>& blocks,
                                  std::vector<double>& rows) {
  rows.resize(9 * blocks.size());
  for (std::size_t k = 0; k < blocks.size(); ++k)
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) rows[9 * k + 3 * r + c] = blocks[k](r, c);
  return rows;
}

static_assert(sizeof(Eigen::Vector3d) == 3 * sizeof(double),
              "ObjectForces::forces must be contiguous xyz triples");

/// An object's degraded states (a few inverted tets left out) are said at most this often,
/// after the first of a run.
constexpr std::chrono::seconds kDegradedWindow{1};

/// Topologies at least this large return freed memory to the OS after their build.
constexpr std::size_t kTrimAfterTets = 100'000;

double ms_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

/// Value at fraction q (0..1) of a sample (reordered), nearest rank.
double percentile(std::vector<double>& values, double q) {
  if (values.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(q * static_cast<double>(values.size() - 1) + 0.5);
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

/// A new ContactForces.answer_id for one frame computation: unique within the process
/// (every scene draws from it) and, seeded from the clock, different from the ids of an
/// earlier run of the service, whose answers a client may still hold.
std::uint64_t next_answer_id() {
  static std::atomic<std::uint64_t> next{
      static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                     std::chrono::system_clock::now().time_since_epoch())
                                     .count())};
  return next.fetch_add(1, std::memory_order_relaxed);
}

/// The deliberate leak of test_leak_bytes_per_removal(): the blocks stay reachable (so a
/// leak checker does not report them) but are never given back.
void keep_for_test(std::size_t bytes) {
  static std::mutex mutex;
  static std::vector<std::unique_ptr<char[]>> kept;
  auto block = std::make_unique<char[]>(bytes);
  std::memset(block.get(), 0x5a, bytes);  // resident, not just reserved
  std::lock_guard lock(mutex);
  kept.push_back(std::move(block));
}

}  // namespace

std::size_t test_leak_bytes_per_removal() {
  static const std::size_t bytes = [] {
    const char* v = std::getenv("TETCOLLIDED_TEST_LEAK_BYTES_PER_REMOVAL");
    return v == nullptr ? std::size_t{0} : static_cast<std::size_t>(std::strtoull(v, nullptr, 10));
  }();
  return bytes;
}

SceneRunner::SceneRunner(std::string scene, const PipelineConfig& config, Outbox& outbox,
                         TopologyResultSink on_topology, double timing_summary_period_s,
                         std::shared_ptr<SceneMetrics> metrics)
    : scene_(std::move(scene)),
      pipeline_(config),
      outbox_(outbox),
      on_topology_(std::move(on_topology)),
      metrics_(std::move(metrics)),
      summary_period_(timing_summary_period_s) {}

void SceneRunner::run(SceneJob& job) {
  std::visit(
      [this](auto& j) {
        using T = std::decay_t<decltype(j)>;
        if constexpr (std::is_same_v<T, TopologyJob>) {
          run_topology(j);
        } else if constexpr (std::is_same_v<T, RemoveJob>) {
          run_remove(j);
        } else if constexpr (std::is_same_v<T, VerdictJob>) {
          run_verdict(j);
        } else {
          run_frame(j);
        }
      },
      job);
}

void SceneRunner::run_topology(TopologyJob& job) {
  const auto start = Clock::now();
  auto* surface = std::get_if<SurfaceMesh>(&job.mesh);
  const Index nodes = surface ? surface->num_nodes() : std::get<TetMesh>(job.mesh).num_nodes();
  const Index cells = surface ? surface->num_triangles() : std::get<TetMesh>(job.mesh).num_tets();
  const std::string cells_text =
      std::to_string(cells) + (surface ? " triangles (a surface)" : " tets");
  Status st = Error{ErrorCode::kInvalidMesh, {}};
  try {
    st = surface ? pipeline_.set_surface(job.object, job.version, std::move(*surface), job.params)
                 : pipeline_.set_topology(job.object, job.version,
                                          std::get<TetMesh>(std::move(job.mesh)), job.params);
  } catch (const std::exception& e) {
    st = Error{ErrorCode::kInvalidArgument, std::string("internal error: ") + e.what()};
  }
  const double build_ms = ms_between(start, Clock::now());
  // Building a large object frees big temporaries (the received sample, the build's
  // scratch arrays); glibc keeps freed heap memory resident unless asked to return it.
  // Once per topology version, so the few milliseconds this takes do not matter.
  if (static_cast<std::size_t>(cells) >= kTrimAfterTets) malloc_trim(0);
  StatusMessage msg;
  msg.scene = scene_;
  msg.object = job.object;
  msg.topology_version = job.version;
  msg.topology_timestamp = job.source_timestamp;
  if (st) {
    active_[job.object] = job.version;
    failed_.erase(job.object);
    if (metrics_) metrics_->set_objects(active_.size());
    // A new version has no state yet: the pipeline leaves the object out of contact
    // until its first state of this version (ContactForces.left_out).
    state_frame_.erase(job.object);
    degraded_.erase(job.object);
    msg.kind = StatusKind::kRegistered;
    msg.code = tetcollide_STATUS_OK;
    msg.message = "registered topology version " + std::to_string(job.version) + ": " +
                  std::to_string(nodes) + " nodes, " + cells_text + ", built in " +
                  std::to_string(build_ms) + " ms (" +
                  std::to_string(ms_between(job.received, Clock::now())) + " ms since received)";
    spdlog::info("{}/{}: {}", scene_, job.object, msg.message);
    if (const std::string caps =
            caps_text(pipeline_.stiffness_caps(job.object), job.params.stiffness);
        !caps.empty()) {
      msg.message += "; " + caps;
      spdlog::warn("{}/{}: {}", scene_, job.object, caps);
    }
  } else {
    msg.kind = StatusKind::kError;
    msg.code = status_code(st.error().code);
    msg.message =
        "topology version " + std::to_string(job.version) + " rejected: " + st.error().message;
    spdlog::warn("{}/{}: {}", scene_, job.object, msg.message);
    failed_[job.object] = FailedBuild{job.version, msg.code, msg.message};
  }
  outbox_.publish_status(msg);
  if (on_topology_) on_topology_(TopologyResult{scene_, job.object, job.version, st.ok()});
}

void SceneRunner::run_remove(const RemoveJob& job) {
  pipeline_.remove_object(job.object);
  // The object's mesh, trees and depth map go back to the allocator; glibc keeps such
  // memory resident in the worker's arena unless asked. Without this the daemon's RSS
  // climbed ~0.17 MB per register/unregister cycle for 40 cycles before levelling off
  // (24 MB after 60 cycles); with it, it stays in a 16.4-18.6 MB band
  // (docs/RELIABILITY.md "Soak"). Removals are rare, so its cost does not matter.
  malloc_trim(0);
  const auto it = active_.find(job.object);
  if (it == active_.end()) return;
  StatusMessage msg;
  msg.kind = StatusKind::kRemoved;
  msg.code = tetcollide_STATUS_OK;
  msg.scene = scene_;
  msg.object = job.object;
  msg.topology_version = it->second;
  msg.message = "object removed";
  active_.erase(it);
  state_frame_.erase(job.object);
  degraded_.erase(job.object);
  if (metrics_) metrics_->set_objects(active_.size());
  if (const std::size_t leak = test_leak_bytes_per_removal(); leak > 0) keep_for_test(leak);
  spdlog::info("{}/{}: removed", scene_, job.object);
  outbox_.publish_status(msg);
}

void SceneRunner::run_verdict(const VerdictJob& job) {
  StatusMessage msg;
  msg.scene = scene_;
  msg.object = job.object;
  msg.topology_version = job.version;
  msg.topology_timestamp = job.source_timestamp;
  const auto active = active_.find(job.object);
  const auto failed = failed_.find(job.object);
  if (active != active_.end() && active->second == job.version) {
    msg.kind = StatusKind::kRegistered;
    msg.code = tetcollide_STATUS_OK;
    msg.message = "topology version " + std::to_string(job.version) +
                  " unchanged: already registered with the same content (not rebuilt)";
  } else if (failed != failed_.end() && failed->second.version == job.version) {
    msg.kind = StatusKind::kError;
    msg.code = failed->second.code;
    msg.message = failed->second.message + " (re-sent unchanged)";
  } else {
    msg.kind = StatusKind::kError;
    msg.code = tetcollide_STATUS_UNKNOWN_OBJECT;
    msg.message = "topology version " + std::to_string(job.version) +
                  " re-sent unchanged, but the object was removed before it was judged";
  }
  spdlog::debug("{}/{}: {}", scene_, job.object, msg.message);
  outbox_.publish_status(msg);
}

void SceneRunner::run_frame(FrameJob& job) {
  const auto start = Clock::now();
  FrameOutput output;
  bool failed = false;
  try {
    // The job's states were made for this frame: the pipeline takes their matrices
    // rather than copying them (only the object names are read below).
    output = pipeline_.run_frame_taking(job.frame, job.states);
  } catch (const std::exception& e) {
    failed = true;
    output = FrameOutput{};
    output.frame = job.frame;
    spdlog::error("{}: frame {} failed: {}", scene_, job.frame, e.what());
    StatusMessage msg;
    msg.kind = StatusKind::kError;
    msg.code = tetcollide_STATUS_INTERNAL;
    msg.scene = scene_;
    msg.frame = job.frame;
    msg.message = std::string("frame not computed: ") + e.what();
    outbox_.publish_status(msg);
  }
  const auto computed = Clock::now();
  // Every answer of this computation carries its id: a client combines only answers of
  // one computation (docs/PROTOCOL.md, "Newest wins").
  const std::uint64_t answer_id = next_answer_id();
  for (const auto& err : output.errors) {
    StatusMessage msg;
    msg.kind = StatusKind::kError;
    msg.code = status_code(err.error.code);
    msg.scene = scene_;
    msg.object = err.object;
    const auto it = active_.find(err.object);
    msg.topology_version = it == active_.end() ? 0 : it->second;
    msg.frame = job.frame;
    msg.message = err.error.message;
    spdlog::warn("{}/{}: frame {} rejected: {}", scene_, err.object, job.frame, err.error.message);
    outbox_.publish_status(msg);
  }
  report_degraded(job, output);
  if (failed) {
    // Every object is answered with the internal error so no client waits in vain.
    for (const auto& [name, version] : active_)
      outbox_.publish_forces(
          rejected_answer(scene_, name, job.frame, version, tetcollide_STATUS_INTERNAL));
  } else {
    // The positions each object now holds in the pipeline came from these states.
    for (std::size_t i = 0; i < job.states.size() && i < job.state_frames.size(); ++i) {
      const std::string& name = job.states[i].object;
      const bool rejected = std::any_of(output.errors.begin(), output.errors.end(),
                                        [&](const auto& e) { return e.object == name; });
      if (!rejected && active_.count(name) != 0) state_frame_[name] = job.state_frames[i];
    }
    if (!output.left_out.empty() && spdlog::should_log(spdlog::level::debug)) {
      std::string names;
      for (const auto& n : output.left_out) names += (names.empty() ? "" : ", ") + n;
      spdlog::debug("{}: frame {}: left out (no state of their topology version yet): {}", scene_,
                    job.frame, names);
    }
    publish_answers(job, output, answer_id);
  }
  const auto published = Clock::now();

  StatsMessage stats;
  stats.scene = scene_;
  stats.frame = job.frame;
  stats.assembly_ms = ms_between(job.first_received, job.dispatched);
  stats.queue_ms = ms_between(job.dispatched, start);
  stats.core = output.stats;
  if (stats.core.total_ms <= 0.0) stats.core.total_ms = ms_between(start, computed);
  stats.publish_ms = ms_between(computed, published);
  stats.objects = static_cast<std::uint32_t>(active_.size());
  stats.states = static_cast<std::uint32_t>(job.states.size());
  stats.rejected = static_cast<std::uint32_t>(job.rejected.size() + output.errors.size());
  stats.dropped_frames = job.dropped_frames;
  outbox_.publish_stats(stats);

  const double latency = ms_between(job.first_received, published);
  if (spdlog::should_log(spdlog::level::debug))
    spdlog::debug(
        "{}: frame {}{}: {} objects, {} states, {} rejected; assembly {:.3f} ms, queue {:.3f} "
        "ms, compute {:.3f} ms (broad {:.3f}, narrow {:.3f}, depth {:.3f}, response {:.3f}), "
        "publish {:.3f} ms; {} candidate / {} overlapping pairs, {} contacts",
        scene_, job.frame, job.complete ? "" : " (partial)", stats.objects, stats.states,
        stats.rejected, stats.assembly_ms, stats.queue_ms, stats.core.total_ms, stats.core.broad_ms,
        stats.core.narrow_ms, stats.core.depth_ms, stats.core.response_ms, stats.publish_ms,
        stats.core.candidate_pairs, stats.core.overlapping_pairs, stats.core.contacts);
  report_timing(stats.core.total_ms, latency);
  if (metrics_)
    metrics_->frame_done(stats.core.total_ms / 1e3, latency / 1e3, active_.size(),
                         stats.core.contacts, job.dropped_frames);
}

void SceneRunner::publish_answers(const FrameJob& job, const FrameOutput& output,
                                  std::uint64_t answer_id) {
  // Index the pipeline's per-object results by name.
  std::vector<const ObjectForces*> forces;
  forces.reserve(output.forces.size());
  for (const auto& f : output.forces) forces.push_back(&f);
  std::sort(forces.begin(), forces.end(),
            [](const ObjectForces* a, const ObjectForces* b) { return a->object < b->object; });
  const auto find_forces = [&](const std::string& name) -> const ObjectForces* {
    const auto it =
        std::lower_bound(forces.begin(), forces.end(), name,
                         [](const ObjectForces* f, const std::string& n) { return f->object < n; });
    return it != forces.end() && (*it)->object == name ? *it : nullptr;
  };
  const auto error_of = [&](const std::string& name) -> std::int32_t {
    for (const auto& r : job.rejected)
      if (r.object == name) return r.code;
    for (const auto& e : output.errors)
      if (e.object == name) return status_code(e.error.code);
    return tetcollide_STATUS_OK;
  };

  ForcesMessage msg;
  msg.scene = scene_;
  msg.frame = job.frame;
  msg.answer_id = answer_id;
  for (const auto& [name, version] : active_) {
    msg.object = name;
    msg.topology_version = version;
    msg.status = error_of(name);
    const auto sf = state_frame_.find(name);
    msg.state_frame = msg.status != tetcollide_STATUS_OK ? job.frame
                      : sf != state_frame_.end()         ? sf->second
                                                         : -1;
    msg.nodes = {};
    msg.forces = {};
    msg.stiffness = {};
    msg.damping = {};
    msg.contacts = nullptr;
    // Rejected answers carry no forces, no computation id and no left-out list.
    const bool ok = msg.status == tetcollide_STATUS_OK;
    msg.answer_id = ok ? answer_id : 0;
    msg.left_out =
        ok ? std::span<const std::string>(output.left_out) : std::span<const std::string>();
    const ObjectForces* f = msg.status == tetcollide_STATUS_OK ? find_forces(name) : nullptr;
    if (f != nullptr && !f->nodes.empty()) {
      msg.nodes = f->nodes;
      msg.forces = {reinterpret_cast<const double*>(f->forces.data()), 3 * f->forces.size()};
      if (f->stiffness.size() == f->nodes.size()) {
        msg.stiffness = row_major(f->stiffness, stiffness_rows_);
        msg.damping = row_major(f->damping, damping_rows_);
      }
    }
    if (ok)
      for (const ObjectContacts& c : output.contacts)
        if (c.object == name) msg.contacts = &c;
    outbox_.publish_forces(msg);
  }
  // Objects the scene does not hold (rejected before or by the pipeline) get their
  // answer too, so their simulator knows the frame is done.
  // Like every rejected answer: topology_version = the version the scene holds for the
  // object (none: 0), answer_id 0.
  const auto answer_unheld = [&](const std::string& name, std::int32_t code) {
    if (active_.count(name) != 0) return;
    outbox_.publish_forces(rejected_answer(scene_, name, job.frame, 0, code));
  };
  for (const auto& r : job.rejected) answer_unheld(r.object, r.code);
  for (const auto& e : output.errors) {
    const bool already = std::any_of(job.rejected.begin(), job.rejected.end(),
                                     [&](const RejectedState& r) { return r.object == e.object; });
    if (already) continue;
    answer_unheld(e.object, status_code(e.error.code));
  }
}

void SceneRunner::report_degraded(const FrameJob& job, const FrameOutput& output) {
  const auto now = Clock::now();
  for (const DegradedState& d : output.degraded) {
    auto [it, first] = degraded_.try_emplace(d.object);
    DegradedRun& run = it->second;
    ++run.states;
    if (!first && now - run.said < kDegradedWindow) {
      ++run.unsaid;
      continue;
    }
    std::string tets;
    for (std::size_t i = 0; i < d.tets.size() && i < 8; ++i)
      tets += (i ? ", " : "") + std::to_string(d.tets[i]);
    if (d.tets.size() > 8) tets += ", ...";
    StatusMessage msg;
    msg.kind = StatusKind::kError;  // a notice about an input; code 0: nothing rejected
    msg.code = tetcollide_STATUS_OK;
    msg.scene = scene_;
    msg.object = d.object;
    const auto active = active_.find(d.object);
    msg.topology_version = active == active_.end() ? 0 : active->second;
    msg.frame = job.frame;
    msg.message = "state accepted with " + std::to_string(d.inverted) + " inverted and " +
                  std::to_string(d.degenerate) + " degenerate tets (" + tets +
                  ") left out of contact (at most " + std::to_string(d.allowed) +
                  " allowed: pipeline.max_inverted_tets, max_inverted_fraction)";
    if (run.unsaid > 0)
      msg.message +=
          "; " + std::to_string(run.unsaid) + " more degraded states since the last notice";
    spdlog::warn("{}/{}: frame {}: {}", scene_, d.object, job.frame, msg.message);
    outbox_.publish_status(msg);
    run.said = now;
    run.unsaid = 0;
  }
  if (degraded_.empty()) return;
  // A clean state ends an object's run: its tets all take part again.
  for (const FrameObjectInput& state : job.states) {
    const auto it = degraded_.find(state.object);
    if (it == degraded_.end()) continue;
    const auto named = [&](const auto& list) {
      return std::any_of(list.begin(), list.end(),
                         [&](const auto& e) { return e.object == state.object; });
    };
    if (named(output.degraded) || named(output.errors)) continue;
    spdlog::info("{}/{}: frame {}: a clean state again after {} degraded states", scene_,
                 state.object, job.frame, it->second.states);
    degraded_.erase(it);
  }
}

void SceneRunner::report_timing(double compute_ms, double latency_ms) {
  if (summary_period_.count() <= 0.0) return;
  compute_ms_.push_back(compute_ms);
  latency_ms_.push_back(latency_ms);
  const auto now = Clock::now();
  if (now - summary_start_ < summary_period_) return;
  const double seconds = std::chrono::duration<double>(now - summary_start_).count();
  const std::size_t frames = compute_ms_.size();
  const double c50 = percentile(compute_ms_, 0.5);
  const double c99 = percentile(compute_ms_, 0.99);
  const double l50 = percentile(latency_ms_, 0.5);
  const double l99 = percentile(latency_ms_, 0.99);
  spdlog::info(
      "{}: {} frames in {:.1f} s; compute p50 {:.3f} ms p99 {:.3f} ms; first state -> "
      "forces published p50 {:.3f} ms p99 {:.3f} ms",
      scene_, frames, seconds, c50, c99, l50, l99);
  compute_ms_.clear();
  latency_ms_.clear();
  summary_start_ = now;
}

}  // namespace tc::daemon
