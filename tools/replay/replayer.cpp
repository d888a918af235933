#include "replayer.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <memory>
#include <set>
#include <thread>
#include <vector>

namespace tc::replay {
namespace {

using Clock = std::chrono::steady_clock;
constexpr std::size_t kMaxListedMismatches = 10;

/// One frame of one scene: its states (the last one per object) and recorded answers.
struct Step {
  std::string scene;
  std::int64_t frame = 0;
  double t = 0.0;  ///< time of its first state
  std::map<std::string, const StateRecord*> states;
  std::map<std::string, const ForcesRecord*> forces;
};

/// Topologies, removals and frames in recorded order.
struct Event {
  double t = 0.0;
  const TopologyRecord* topology = nullptr;
  const RemoveRecord* remove = nullptr;
  std::size_t step = 0;  ///< valid when both pointers are null
};

/// |a - b| maximum over the union of nodes (a missing node has zero force).
double deviation(const ForcesRecord& want, const client::ObjectForces& got) {
  std::map<std::int32_t, std::array<double, 3>> diff;
  for (std::size_t k = 0; k < want.nodes.size() && 3 * k + 2 < want.forces.size(); ++k)
    diff[want.nodes[k]] = {want.forces[3 * k], want.forces[3 * k + 1], want.forces[3 * k + 2]};
  for (std::size_t k = 0; k < got.nodes.size() && 3 * k + 2 < got.forces.size(); ++k) {
    auto& d = diff[got.nodes[k]];
    for (int c = 0; c < 3; ++c)
      d[static_cast<std::size_t>(c)] -= got.forces[3 * k + static_cast<std::size_t>(c)];
  }
  double out = 0.0;
  for (const auto& [node, d] : diff)
    for (const double v : d) out = std::max(out, std::abs(v));
  return out;
}

/// Same bytes (memcmp on empty vectors would pass null pointers, which memcmp forbids).
bool same_bytes(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

/// A recording made before protocol 3 has no df/dv blocks: they are then not compared.
bool identical(const ForcesRecord& want, const client::ObjectForces& got) {
  return want.status == got.status && want.nodes == got.nodes &&
         same_bytes(want.forces, got.forces) && same_bytes(want.stiffness, got.stiffness) &&
         (want.damping.empty() || same_bytes(want.damping, got.damping));
}

}  // namespace

double percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const auto k = static_cast<std::size_t>(std::ceil(q * static_cast<double>(values.size())));
  return values[std::min(values.size() - 1, k == 0 ? 0 : k - 1)];
}

Expected<ReplayReport> replay(const std::vector<Record>& records, const ReplayOptions& options) {
  // Group states and forces into steps keyed by (scene, frame), in order of first state.
  std::vector<Step> steps;
  std::map<std::pair<std::string, std::int64_t>, std::size_t> step_of;
  std::vector<Event> events;
  for (const auto& rec : records) {
    if (const auto* s = std::get_if<StateRecord>(&rec)) {
      const auto key = std::make_pair(s->scene, s->frame);
      auto it = step_of.find(key);
      if (it == step_of.end()) {
        it = step_of.emplace(key, steps.size()).first;
        steps.push_back(Step{s->scene, s->frame, s->t, {}, {}});
        events.push_back(Event{s->t, nullptr, nullptr, it->second});
      }
      steps[it->second].states[s->object] = s;
    } else if (const auto* t = std::get_if<TopologyRecord>(&rec)) {
      events.push_back(Event{t->t, t, nullptr, 0});
    } else if (const auto* r = std::get_if<RemoveRecord>(&rec)) {
      events.push_back(Event{r->t, nullptr, r, 0});
    }
  }
  for (const auto& rec : records)
    if (const auto* f = std::get_if<ForcesRecord>(&rec)) {
      const auto it = step_of.find({f->scene, f->frame});
      if (it != step_of.end()) steps[it->second].forces[f->object] = f;
    }
  std::stable_sort(events.begin(), events.end(),
                   [](const Event& a, const Event& b) { return a.t < b.t; });

  std::map<std::string, std::unique_ptr<client::Client>> clients;
  const auto client_for = [&](const std::string& scene) -> client::Client& {
    auto& c = clients[scene];
    if (!c) {
      client::Options o;
      o.domain = options.domain;
      o.scene = scene;
      o.partition = options.partition;
      o.resend_after = options.resend_after;
      c = client::Client::connect(o);
    }
    return *c;
  };
  // Topologies applied so far: (scene, object) -> version.
  std::map<std::pair<std::string, std::string>, std::uint32_t> registered;
  std::set<const TopologyRecord*> applied;
  const auto apply_topology = [&](const TopologyRecord& t) {
    if (!applied.insert(&t).second) return;
    client_for(t.scene).register_object(t.object, t.mesh, t.params, t.version);
    registered[{t.scene, t.object}] = t.version;
  };

  // True when the next recorded state of t's object (from event `from` on) still uses an
  // older version than t: the recorder stamps each topic as it reads it, so a new
  // version can be recorded just before the last states of the previous one; sending it
  // at its recorded time would make those states stale. Such a topology waits until
  // the states before it are sent (it is sent at the latest with the first state that
  // uses it, below).
  const auto older_states_pending = [&](std::size_t from, const TopologyRecord& t) {
    for (std::size_t k = from; k < events.size(); ++k) {
      if (events[k].topology != nullptr || events[k].remove != nullptr) continue;
      const Step& st = steps[events[k].step];
      if (st.scene != t.scene) continue;
      const auto it = st.states.find(t.object);
      if (it != st.states.end()) return it->second->topology_version < t.version;
    }
    return false;
  };
  std::vector<const TopologyRecord*> waiting;

  ReplayReport report;
  std::vector<double> latencies;
  try {
    bool service_checked = false;
    const auto start = Clock::now();
    const double t0 = events.empty() ? 0.0 : events.front().t;
    std::size_t index = 0;
    for (std::size_t e = 0; e < events.size(); ++e) {
      const Event& ev = events[e];
      std::erase_if(waiting, [&](const TopologyRecord* t) {
        if (older_states_pending(e, *t)) return false;
        apply_topology(*t);
        return true;
      });
      if (ev.topology != nullptr) {
        if (older_states_pending(e + 1, *ev.topology))
          waiting.push_back(ev.topology);
        else
          apply_topology(*ev.topology);
        continue;
      }
      if (ev.remove != nullptr) {
        const auto key = std::make_pair(ev.remove->scene, ev.remove->object);
        if (registered.count(key) != 0) {
          client_for(ev.remove->scene).remove_object(ev.remove->object);
          registered.erase(key);
        }
        continue;
      }
      const Step& step = steps[ev.step];
      client::Client& c = client_for(step.scene);
      if (!service_checked) {
        if (!c.wait_for_service(options.service_timeout))
          return Error{ErrorCode::kIo, "no tetcollided announced READY on domain " +
                                           std::to_string(options.domain) + " within " +
                                           std::to_string(options.service_timeout.count()) + " ms"};
        if (options.services > 1 && !c.wait_for_readers(options.services, options.service_timeout))
          return Error{ErrorCode::kIo, "fewer than " + std::to_string(options.services) +
                                           " services read the states on domain " +
                                           std::to_string(options.domain) + " after " +
                                           std::to_string(options.service_timeout.count()) + " ms"};
        service_checked = true;
      }
      // A topology recorded just after a state that needs it (the topics are not ordered
      // with respect to each other) is sent first.
      for (const auto& [object, s] : step.states) {
        const auto key = std::make_pair(step.scene, object);
        const auto it = registered.find(key);
        if (it != registered.end() && it->second == s->topology_version) continue;
        for (const auto& later : events)
          if (later.topology != nullptr && later.topology->scene == step.scene &&
              later.topology->object == object && later.topology->version == s->topology_version) {
            apply_topology(*later.topology);
            break;
          }
      }
      // Every registration of this step's objects is confirmed before the frame goes,
      // so the answer does not depend on how fast the service builds a mesh.
      for (const auto& [object, s] : step.states)
        if (registered.count({step.scene, object}) != 0)
          c.wait_registered(object, options.frame_timeout);
      if (options.rate > 0.0) {
        const auto due = start + std::chrono::duration_cast<Clock::duration>(
                                     std::chrono::duration<double>((ev.t - t0) / options.rate));
        std::this_thread::sleep_until(due);
      }
      if (options.before_frame) options.before_frame(index, step.scene, step.frame);
      ++index;

      std::vector<client::ObjectState> states;
      for (const auto& [object, s] : step.states) {
        client::ObjectState o;
        o.object = object;
        o.positions = s->positions;
        o.velocities = s->velocities;
        o.topology_version = s->topology_version;
        states.push_back(o);
      }
      const auto sent = Clock::now();
      c.publish_states(step.frame, states);
      auto answer = c.wait_forces(step.frame, options.frame_timeout);
      const double latency = std::chrono::duration<double, std::milli>(Clock::now() - sent).count();
      // Objects answered without a state in this frame (static ones) may come a moment
      // after the others.
      const auto settle = Clock::now() + std::chrono::milliseconds(500);
      while (answer && answer->frame == step.frame && Clock::now() < settle &&
             std::any_of(step.forces.begin(), step.forces.end(),
                         [&](const auto& f) { return answer->find(f.first) == nullptr; })) {
        c.poll(std::chrono::milliseconds(5));
        answer = c.wait_forces(step.frame, std::chrono::milliseconds(0));
      }
      ++report.frames;
      if (!answer || answer->frame != step.frame) {
        ++report.unanswered;
        if (options.check && !step.forces.empty()) {
          ++report.mismatched_frames;
          if (report.mismatches.size() < kMaxListedMismatches)
            report.mismatches.push_back(step.scene + " frame " + std::to_string(step.frame) +
                                        ": no answer");
        }
        continue;
      }
      latencies.push_back(latency);
      if (!options.check) continue;
      bool mismatch = false;
      for (const auto& [object, want] : step.forces) {
        const client::ObjectForces* got = answer->find(object);
        if (got == nullptr) {
          mismatch = true;
          if (report.mismatches.size() < kMaxListedMismatches)
            report.mismatches.push_back(step.scene + "/" + object + " frame " +
                                        std::to_string(step.frame) + ": no answer");
          continue;
        }
        const double d = deviation(*want, *got);
        report.max_force_deviation = std::max(report.max_force_deviation, d);
        if (!identical(*want, *got)) {
          mismatch = true;
          if (report.mismatches.size() < kMaxListedMismatches)
            report.mismatches.push_back(
                step.scene + "/" + object + " frame " + std::to_string(step.frame) + ": status " +
                std::to_string(got->status) + " (recorded " + std::to_string(want->status) + "), " +
                std::to_string(got->nodes.size()) + " nodes (recorded " +
                std::to_string(want->nodes.size()) + "), max deviation " + std::to_string(d) +
                " N");
        }
      }
      if (mismatch) ++report.mismatched_frames;
    }
    for (const TopologyRecord* t : waiting) apply_topology(*t);
  } catch (const client::ClientError& e) {
    return Error{ErrorCode::kIo, e.what()};
  } catch (const std::invalid_argument& e) {
    return Error{ErrorCode::kInvalidArgument, e.what()};
  }
  report.latency_ms_p50 = percentile(latencies, 0.50);
  report.latency_ms_p99 = percentile(latencies, 0.99);
  return report;
}

}  // namespace tc::replay
