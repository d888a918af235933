// Shards with hot standbys (issue 15): a primary (ownership strength 20) and a standby
// (10) serve the same scenes on two hosts, the simulator runs on a third (VirtualLan with
// a bridge). Both daemons compute every frame; the client sees only the answers of the
// strongest live one (ContactForces and FrameStats have EXCLUSIVE ownership). SIGKILL the
// primary: the standby's answers reach the client once the primary's liveliness lease
// (1 s) expired; a returning primary takes over again. The streaming tests measure the
// failover at 60 Hz and 1 kHz (docs/DEPLOYMENT.md, "Failover measured"). Needs root;
// skips with the reason elsewhere. Label: integration, hosts.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

#include "daemon_process.hpp"
#include "protocol.hpp"
#include "recording.hpp"
#include "replay_options.hpp"
#include "replayer.hpp"
#include "sanitizer.hpp"
#include "scenes.hpp"
#include "tetcollide/client.hpp"
#include "virtual_lan.hpp"

namespace tc::itest {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

constexpr int kPrimary = 0;
constexpr int kStandby = 1;
constexpr int kClientHost = 2;

/// CPU seconds (user + system) a process used so far, from /proc/<pid>/stat; -1 when
/// unreadable.
double cpu_seconds(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string text;
  std::getline(in, text);
  const auto close = text.rfind(')');
  if (close == std::string::npos) return -1.0;
  std::istringstream fields(text.substr(close + 2));
  std::string f;
  double utime = 0.0;
  double stime = 0.0;
  // After the command: state(3) ... utime(14) stime(15).
  for (int i = 3; i <= 15 && fields >> f; ++i) {
    if (i == 14) utime = std::stod(f);
    if (i == 15) stime = std::stod(f);
  }
  return (utime + stime) / static_cast<double>(sysconf(_SC_CLK_TCK));
}

/// Which daemon each ContactForces sample the client side receives comes from: a plain
/// DDS participant with the protocol's readers (EXCLUSIVE forces reader, as every client),
/// mapping each sample's writer to its participant and the participant to the
/// service_id of the ServiceStatus samples it wrote.
class AnswerObserver {
 public:
  struct Answer {
    std::string object;
    std::int64_t frame = 0;
    std::string service;  ///< "" when the writer was already gone when taken
    std::string scene;
    dds_time_t written = 0;  ///< source timestamp: when the daemon wrote it, ns
  };

  /// Observes the answers of scenes whose name begins with `scene_prefix` (the whole
  /// name for one scene).
  AnswerObserver(std::uint32_t domain, std::string scene_prefix) : scene_(std::move(scene_prefix)) {
    participant_ = dds_create_participant(domain, nullptr, nullptr);
    if (participant_ < 0) {
      error_ = "dds_create_participant: " + protocol::dds_error(participant_);
      return;
    }
    forces_ = make_reader(protocol::Topic::kForces, 64);
    status_ = make_reader(protocol::Topic::kStatus, 4096);
  }
  ~AnswerObserver() {
    if (participant_ > 0) dds_delete(participant_);
  }
  AnswerObserver(const AnswerObserver&) = delete;
  AnswerObserver& operator=(const AnswerObserver&) = delete;

  [[nodiscard]] const std::string& error() const { return error_; }

  /// Takes what arrived; call often (a writer of a dead daemon is forgotten after its
  /// lease, and its samples taken later cannot be attributed).
  void poll() {
    take<tetcollide_ServiceStatus>(
        status_, [&](const tetcollide_ServiceStatus& s, const dds_sample_info_t& info) {
          if (const auto key = participant_of(status_, info.publication_handle))
            services_[*key] = s.service_id;
        });
    take<tetcollide_ContactForces>(
        forces_, [&](const tetcollide_ContactForces& s, const dds_sample_info_t& info) {
          const std::string_view scene = protocol::bounded_view(s.scene);
          if (scene.substr(0, scene_.size()) != scene_) return;
          Answer a{std::string(protocol::bounded_view(s.object)),
                   s.frame,
                   {},
                   std::string(scene),
                   info.source_timestamp};
          if (const auto key = participant_of(forces_, info.publication_handle)) {
            const auto it = services_.find(*key);
            if (it != services_.end()) {
              a.service = it->second;
            } else {
              unresolved_.emplace_back(answers_.size(), *key);
            }
          }
          answers_.push_back(std::move(a));
        });
    // A daemon's first answers may arrive before its first status sample.
    std::erase_if(unresolved_, [&](const std::pair<std::size_t, Key>& u) {
      const auto it = services_.find(u.second);
      if (it == services_.end()) return false;
      answers_[u.first].service = it->second;
      return true;
    });
  }
  [[nodiscard]] const std::vector<Answer>& answers() const { return answers_; }

  /// Waits until `count` live ContactForces writers (daemons) are matched. False on
  /// timeout or a DDS error (then error() says which).
  bool wait_for_writers(std::uint32_t count, std::chrono::milliseconds timeout) {
    const auto deadline = Clock::now() + timeout;
    for (;;) {
      dds_subscription_matched_status_t st{};
      if (const dds_return_t rc = dds_get_subscription_matched_status(forces_, &st); rc < 0) {
        error_ = "dds_get_subscription_matched_status: " + protocol::dds_error(rc);
        return false;
      }
      if (st.current_count >= count) return true;
      if (Clock::now() >= deadline) return false;
      std::this_thread::sleep_for(5ms);
    }
  }

 private:
  using Key = std::string;  // participant GUID bytes

  dds_entity_t make_reader(protocol::Topic topic, std::int32_t depth) {
    const auto qos = protocol::topic_qos(topic);
    const dds_entity_t t = dds_create_topic(participant_, protocol::topic_descriptor(topic),
                                            protocol::topic_name(topic), qos.get(), nullptr);
    if (t < 0) {
      error_ = std::string("dds_create_topic(") + protocol::topic_name(topic) +
               "): " + protocol::dds_error(t);
      return t;
    }
    if (depth > 0) dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, depth);
    const dds_entity_t r = dds_create_reader(participant_, t, qos.get(), nullptr);
    if (r < 0)
      error_ = std::string("dds_create_reader(") + protocol::topic_name(topic) +
               "): " + protocol::dds_error(r);
    return r;
  }

  std::optional<Key> participant_of(dds_entity_t reader, dds_instance_handle_t writer) {
    dds_builtintopic_endpoint_t* ep = dds_get_matched_publication_data(reader, writer);
    if (ep == nullptr) return std::nullopt;
    Key key(reinterpret_cast<const char*>(ep->participant_key.v), sizeof ep->participant_key.v);
    dds_builtintopic_free_endpoint(ep);
    return key;
  }

  template <typename T, typename F>
  void take(dds_entity_t reader, F&& on_sample) {
    if (reader <= 0) return;
    for (;;) {
      void* samples[64] = {};
      dds_sample_info_t infos[64];
      const dds_return_t n = dds_take(reader, samples, infos, 64, 64);
      if (n < 0) {
        error_ = "dds_take: " + protocol::dds_error(n);
        return;
      }
      for (dds_return_t i = 0; i < n; ++i)
        if (infos[i].valid_data) on_sample(*static_cast<const T*>(samples[i]), infos[i]);
      if (n > 0)
        if (const dds_return_t rc = dds_return_loan(reader, samples, n); rc < 0) {
          error_ = "dds_return_loan: " + protocol::dds_error(rc);
          return;
        }
      if (n < 64) return;
    }
  }

  std::string scene_;
  std::string error_;
  dds_entity_t participant_ = -1;
  dds_entity_t forces_ = -1;
  dds_entity_t status_ = -1;
  std::map<Key, std::string> services_;
  std::vector<Answer> answers_;
  std::vector<std::pair<std::size_t, Key>> unresolved_;  // answers_ index, writer's participant
};

std::string network_config() {
  return "file://" + program_from_env("TC_NETWORK_CONFIG");
}

class FailoverTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (const std::string why = VirtualLan::unavailable_reason(); !why.empty())
      GTEST_SKIP() << "several-host test skipped: " << why;
    lan_ = std::make_unique<VirtualLan>(3);
    ASSERT_TRUE(lan_->ok()) << lan_->error();
    dir_ = make_temp_dir("itest-failover");
    // This process is the simulator host: its DDS participants (made after this) live
    // in that namespace, on the network config.
    ASSERT_TRUE(lan_->enter(kClientHost)) << lan_->error();
    setenv("TC_DDS_INTERFACE", VirtualLan::kInterface, 1);
    setenv("CYCLONEDDS_URI", network_config().c_str(), 1);
    primary_ = start_daemon(kPrimary, "primary", 20);
    standby_ = start_daemon(kStandby, "standby", 10);
  }
  /// dds.answer_lease_ms of both daemons.
  [[nodiscard]] virtual int answer_lease_ms() const { return 1000; }
  void TearDown() override {
    for (auto* d : {primary_.get(), standby_.get()})
      if (HasFailure() && d != nullptr) std::cerr << "---- daemon log ----\n" << d->log_text();
    primary_.reset();
    standby_.reset();
    lan_.reset();
    if (!dir_.empty()) std::filesystem::remove_all(dir_);
  }

  std::unique_ptr<DaemonProcess> start_daemon(int host, const std::string& name, int strength) {
    const auto dir = dir_ / name;
    std::filesystem::create_directories(dir);
    auto d = std::make_unique<DaemonProcess>(dir, domain_,
                                             "version: 1\n"
                                             "dds:\n"
                                             "  service_id: " +
                                                 name +
                                                 "\n"
                                                 "  status_period_s: 0.2\n"
                                                 "  ownership_strength: " +
                                                 std::to_string(strength) +
                                                 "\n"
                                                 "  answer_lease_ms: " +
                                                 std::to_string(answer_lease_ms()) +
                                                 "\n"
                                                 "  cyclonedds_config: '" +
                                                 network_config() +
                                                 "'\n"
                                                 "log:\n"
                                                 "  timing_summary_period_s: 0\n");
    d->set_command_prefix(lan_->exec_prefix(host));
    EXPECT_TRUE(d->start()) << d->log_text();
    return d;
  }

  std::uint32_t domain_ = private_domain();
  std::unique_ptr<VirtualLan> lan_;
  std::filesystem::path dir_;
  std::unique_ptr<DaemonProcess> primary_;
  std::unique_ptr<DaemonProcess> standby_;
};

std::size_t count_of(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

// The committed two_boxes recording, lock-step: the primary is SIGKILLed before frame 10
// and started again before frame 25 (once it registered the objects again from the
// client's transient-local topologies). Every frame is answered bit for bit as in the
// single-daemon recording; a client's reader (the observer) sees the primary's answers,
// then the standby's, then the primary's again, never both daemons' answers to one frame
// but for the first one of an instance (whichever daemon answers first owns it until the
// stronger one writes) and the first one after the primary's return (the standby still
// owns the instances until then).
TEST_F(FailoverTest, TheStandbyAnswersWhenThePrimaryDiesAndThePrimaryTakesOverAgain) {
  const auto records = replay::read_recording(recordings_dir() / "two_boxes.jsonl");
  ASSERT_TRUE(records) << records.error().message;
  AnswerObserver observer(domain_, "two_boxes");
  ASSERT_EQ(observer.error(), "");
  ASSERT_TRUE(observer.wait_for_writers(2, 20s)) << "the daemons' answer writers never matched";

  replay::ReplayOptions o = checked_replay_options(domain_);
  o.services = 2;
  std::map<std::int64_t, std::string> expected_owner;  // frame -> who must answer it
  std::int64_t kill_frame = -1;                        // the first frame published after the kill
  std::int64_t restart_frame = -1;                     // ... after the primary's return
  std::string owner = "primary";
  bool restarted = false;
  bool primary_back = false;
  o.before_frame = [&](std::size_t index, const std::string&, std::int64_t frame) {
    observer.poll();
    // The returning primary answers once its state reader matched the client's writer
    // too, which may take longer than a few lock-step frames: give it up to 0.5 s per frame.
    for (int i = 0; index > 25 && !primary_back && i < 100; ++i) {
      for (const auto& a : observer.answers())
        primary_back = primary_back || (a.service == "primary" && a.frame >= restart_frame);
      if (!primary_back) {
        std::this_thread::sleep_for(5ms);
        observer.poll();
      }
    }
    if (index == 0) {
      // Both daemons compute from the first frame on (the client's verdict came from one).
      for (auto* d : {primary_.get(), standby_.get()})
        for (const char* object : {"a", "b"})
          EXPECT_TRUE(d->wait_for_log(
              std::string("two_boxes/") + object + ": registered topology version 1", 20s));
    } else if (index == 10) {
      primary_->kill_hard();
      owner = "standby";
      kill_frame = frame;
    } else if (index == 25) {
      restarted = primary_->start() &&
                  primary_->wait_for_log("two_boxes/b: registered topology version 1", 20s) &&
                  observer.wait_for_writers(2, 20s);
      owner = "primary";
      restart_frame = frame;
    }
    expected_owner[frame] = owner;
  };
  const auto report = replay::replay(*records, o);
  ASSERT_TRUE(report) << report.error().message;
  EXPECT_TRUE(restarted);
  EXPECT_EQ(report->frames, 40u);
  EXPECT_EQ(report->unanswered, 0u);
  EXPECT_EQ(report->mismatched_frames, 0u);
  for (const auto& m : report->mismatches) ADD_FAILURE() << m;

  std::this_thread::sleep_for(200ms);
  observer.poll();
  ASSERT_EQ(observer.error(), "");
  // Who answered, as the client's (EXCLUSIVE) reader saw it, in arrival order per object.
  // Ownership of an instance moves with a sample: until the primary's first answer reaches
  // the reader (at the start, and after its return) the standby's answers do too; from
  // then on only the primary's, until it dies; then only the standby's.
  std::map<std::string, std::map<std::string, int>> counts;  // object -> phase/service -> n
  for (const auto& [object, label] : std::map<std::string, std::string>{{"a", "a"}, {"b", "b"}}) {
    bool primary_seen[3] = {false, false, false};
    for (const auto& a : observer.answers()) {
      if (a.object != object) continue;
      const auto it = expected_owner.find(a.frame);
      ASSERT_NE(it, expected_owner.end()) << "an answer to frame " << a.frame << " never sent";
      const int phase = a.frame < kill_frame ? 0 : (a.frame < restart_frame ? 1 : 2);
      ++counts[label][std::to_string(phase) + a.service];
      if (phase == 1) {
        EXPECT_EQ(a.service, "standby") << object << " frame " << a.frame;
      } else if (a.service == "primary") {
        primary_seen[phase] = true;
      } else {
        EXPECT_FALSE(primary_seen[phase])
            << object << " frame " << a.frame << ": " << (a.service.empty() ? "?" : a.service)
            << "'s answer after the primary's";
      }
    }
    EXPECT_TRUE(primary_seen[0]) << object << ": no answer of the primary before the kill";
    EXPECT_TRUE(primary_seen[2]) << object << ": no answer of the primary after its return";
  }
  for (const auto& [object, c] : counts)
    for (const auto& [phase_service, n] : c)
      std::printf("%s answers to frames of phase %s: %d\n", object.c_str(), phase_service.c_str(),
                  n);
  // Every frame got an answer.
  std::set<std::int64_t> answered;
  for (const auto& a : observer.answers()) answered.insert(a.frame);
  EXPECT_EQ(answered.size(), expected_owner.size());
  // The standby received the topologies once, at its start: the client never re-sent them.
  EXPECT_EQ(count_of(standby_->log_text(), "two_boxes/a: registered"), 1u) << standby_->log_text();
}

/// One answered frame as the streaming client received it.
struct Received {
  Clock::time_point at;
  std::string forces;  ///< every object's nodes and force bits, for bit-for-bit comparison
};

std::string forces_bits(const client::FrameForces& ff) {
  std::string s;
  for (const auto& o : ff.objects) {
    s += o.object + ":";
    s.append(reinterpret_cast<const char*>(o.nodes.data()), o.nodes.size() * sizeof o.nodes[0]);
    s.append(reinterpret_cast<const char*>(o.forces.data()), o.forces.size() * sizeof o.forces[0]);
    s += ";";
  }
  return s;
}

struct StreamCase {
  int rate;      ///< frames per second
  int lease_ms;  ///< dds.answer_lease_ms of the daemons
};

class FailoverStreamTest : public FailoverTest, public ::testing::WithParamInterface<StreamCase> {
 protected:
  [[nodiscard]] int answer_lease_ms() const override { return GetParam().lease_ms; }
};

// A simulator streams two overlapping boxes at `rate` Hz without waiting for answers
// (positions repeat every 10 frames); the primary is SIGKILLed after 1.5 s, the stream
// goes on to 4 s. Measured: frames left unanswered, time from the kill to the first
// answer to a frame published after it, the daemons' CPU while both run. Every answer
// after the switch equals, bit for bit, the primary's answer to the same positions.
// With the daemons' answer lease (dds.answer_lease_ms) at 1 s, the protocol's, and 200 ms.
TEST_P(FailoverStreamTest, MeasuresTheFailoverWhileStreaming) {
  const int rate = GetParam().rate;
  const int lease_ms = GetParam().lease_ms;
  client::Options co;
  co.domain = domain_;
  co.scene = "stream";
  auto c = client::Client::connect(co);
  ASSERT_TRUE(c->wait_for_service(20s));
  const client::Mesh a = box_mesh(2, {-0.5, -0.5, -0.5}, {0.5, 0.5, 0.5});
  const client::Mesh b = box_mesh(2, {0.3, -0.4, -0.4}, {1.3, 0.6, 0.6});
  c->register_object("a", a, {});
  c->register_object("b", b, {});
  ASSERT_TRUE(c->wait_registered("a", 10s).ok);
  ASSERT_TRUE(c->wait_registered("b", 10s).ok);
  for (auto* d : {primary_.get(), standby_.get()})
    for (const char* object : {"stream/a: registered", "stream/b: registered"})
      ASSERT_TRUE(d->wait_for_log(object, 10s)) << d->log_text();
  std::vector<std::vector<double>> pa;
  std::vector<std::vector<double>> pb;
  for (int k = 0; k < 10; ++k) {
    pa.push_back(translated(a, {0.0, 0.0, 0.002 * k}));
    pb.push_back(translated(b, {-0.003 * k, 0.0, 0.0}));
  }

  std::mutex mutex;
  std::map<std::int64_t, Received> received;
  c->set_forces_callback([&](const client::FrameForces& ff) {
    for (const auto& o : ff.objects)
      if (o.status != 0 || o.state_frame != ff.frame) return;
    std::lock_guard lock(mutex);
    received.try_emplace(ff.frame, Received{Clock::now(), forces_bits(ff)});
  });

  const int total = rate * 4;
  const int kill_at = rate * 3 / 2;
  const int cpu_from = rate / 2;
  const auto period = std::chrono::duration_cast<Clock::duration>(1s) / rate;
  const pid_t primary_pid = primary_->pid();
  const pid_t standby_pid = standby_->pid();
  double cpu0[2] = {0, 0};
  double cpu1[2] = {0, 0};
  Clock::time_point cpu_t0;
  Clock::time_point kill_time;
  const auto t0 = Clock::now();
  for (int f = 0; f < total; ++f) {
    std::this_thread::sleep_until(t0 + f * period);
    if (f == cpu_from) {
      cpu_t0 = Clock::now();
      cpu0[0] = cpu_seconds(primary_pid);
      cpu0[1] = cpu_seconds(standby_pid);
    }
    if (f == kill_at) {
      cpu1[0] = cpu_seconds(primary_pid);
      cpu1[1] = cpu_seconds(standby_pid);
      kill_time = Clock::now();
      primary_->kill_hard();
    }
    const auto k = static_cast<std::size_t>(f % 10);
    c->publish_states(f, {{"a", pa[k]}, {"b", pb[k]}});
  }
  // The last frame's answer, then the callback is stopped.
  for (int i = 0; i < 500; ++i) {
    {
      std::lock_guard lock(mutex);
      if (received.count(total - 1) != 0) break;
    }
    std::this_thread::sleep_for(10ms);
  }
  c->set_forces_callback(nullptr);
  std::lock_guard lock(mutex);
  ASSERT_EQ(received.count(total - 1), 1u) << "the last frame was never answered";

  const double cpu_window_s = std::chrono::duration<double>(kill_time - cpu_t0).count();
  const double primary_cpu = (cpu1[0] - cpu0[0]) / cpu_window_s;
  const double standby_cpu = (cpu1[1] - cpu0[1]) / cpu_window_s;
  std::map<int, std::string> reference;  // f % 10 -> the primary's answer
  int answered_before = 0;
  for (const auto& [f, r] : received)
    if (f < kill_at) {
      ++answered_before;
      reference.try_emplace(static_cast<int>(f % 10), r.forces);
    }
  ASSERT_EQ(reference.size(), 10u) << "the primary did not answer every position before the kill";
  std::int64_t first_after = -1;
  int mismatched = 0;
  int answered_after = 0;
  for (const auto& [f, r] : received) {
    if (f < kill_at) continue;
    if (first_after < 0) first_after = f;
    ++answered_after;
    if (r.forces != reference[static_cast<int>(f % 10)]) ++mismatched;
  }
  ASSERT_GE(first_after, 0);
  const double resume_ms =
      std::chrono::duration<double, std::milli>(received[first_after].at - kill_time).count();
  const int lost_in_switch = static_cast<int>(first_after) - kill_at;
  const int unanswered_after_switch = total - static_cast<int>(first_after) - answered_after;
  std::printf(
      "failover at %d Hz, answer lease %d ms: primary SIGKILLed at frame %d; first answer after "
      "it: frame %lld, %.0f ms after the kill; %d frames unanswered in the switch, %d "
      "unanswered after it (%d of %d answered before the kill); answers after the switch "
      "bit-identical: %d of %d; CPU while both ran: primary %.1f%%, standby %.1f%% of one "
      "core\n",
      rate, lease_ms, kill_at, static_cast<long long>(first_after), resume_ms, lost_in_switch,
      unanswered_after_switch, answered_before, kill_at, answered_after - mismatched,
      answered_after, 100.0 * primary_cpu, 100.0 * standby_cpu);
  RecordProperty("resume_ms", static_cast<int>(resume_ms));
  RecordProperty("lost_in_switch", lost_in_switch);
  // Within the answer lease plus detection and scheduling slack on a shared CI machine
  // (the slack, not the lease, grows in a sanitizer build).
  EXPECT_LT(resume_ms, lease_ms + 1000.0 * test::kTimeSlack);
  EXPECT_LE(lost_in_switch, rate * (lease_ms + 1000 * static_cast<int>(test::kTimeSlack)) / 1000);
  EXPECT_EQ(mismatched, 0);
  // Frames superseded under load (newest wins) are not failover losses: not bounded here.
  EXPECT_GT(answered_after, 0);
  EXPECT_EQ(count_of(standby_->log_text(), "stream/a: registered"), 1u);
}

INSTANTIATE_TEST_SUITE_P(Rates, FailoverStreamTest,
                         ::testing::Values(StreamCase{60, 1000}, StreamCase{1000, 1000},
                                           StreamCase{60, 200}, StreamCase{1000, 200}),
                         [](const ::testing::TestParamInfo<StreamCase>& param) {
                           return std::to_string(param.param.rate) + "Hz" +
                                  (param.param.lease_ms == 1000
                                       ? std::string()
                                       : "_Lease" + std::to_string(param.param.lease_ms) + "ms");
                         });

// Load split: 4 hosts, 16 scenes in 4 shards (scene patterns shard<i>-*), one daemon per
// host: host i's daemon is shard i's primary (strength 20) and shard i - 1's standby (10)
// through dds.shard_strengths; the 16 simulators (two 27-node boxes each, 20 Hz, not
// waiting for answers) on a fifth host. The daemons are killed (SIGKILL) and restarted in
// turn. A client's reader
// sees every scene answered by one daemon at a time (owner changes: exactly to the
// standby when its primary's host dies and back when it returns), and no scene goes
// without answers for longer than the lease plus 0.5 s.
class LoadSplitTest : public ::testing::Test {
 protected:
  static constexpr int kShards = 4;
  static constexpr int kScenesPerShard = 4;
  static constexpr int kClientHost = kShards;

  void SetUp() override {
    if (const std::string why = VirtualLan::unavailable_reason(); !why.empty())
      GTEST_SKIP() << "several-host test skipped: " << why;
    lan_ = std::make_unique<VirtualLan>(kShards + 1);
    ASSERT_TRUE(lan_->ok()) << lan_->error();
    dir_ = make_temp_dir("itest-loadsplit");
    ASSERT_TRUE(lan_->enter(kClientHost)) << lan_->error();
    setenv("TC_DDS_INTERFACE", VirtualLan::kInterface, 1);
    setenv("CYCLONEDDS_URI", network_config().c_str(), 1);
    for (int host = 0; host < kShards; ++host) daemons_.push_back(make_daemon(host));
    for (auto& d : daemons_) ASSERT_TRUE(d->start()) << d->log_text();
  }
  void TearDown() override {
    for (auto& d : daemons_)
      if (HasFailure()) std::cerr << "---- daemon log ----\n" << d->log_text();
    daemons_.clear();
    lan_.reset();
    if (!dir_.empty()) std::filesystem::remove_all(dir_);
  }

  /// Service id of host i's daemon: "h0".
  static std::string host_name(int host) {
    std::string name = "h";  // (not "h" + ...: GCC 12 warns -Wrestrict on that, wrongly)
    name += std::to_string(host);
    return name;
  }
  /// Host of shard i's primary ('p', host i) or standby ('s', host i + 1).
  static int host_of(char role, int shard) { return role == 'p' ? shard : (shard + 1) % kShards; }
  static std::string role_name(char role, int shard) { return host_name(host_of(role, shard)); }
  std::unique_ptr<DaemonProcess> make_daemon(int host) {
    const std::string name = host_name(host);
    const std::string own = "shard" + std::to_string(host) + "-*";
    const std::string backed = "shard" + std::to_string((host + kShards - 1) % kShards) + "-*";
    const auto dir = dir_ / name;
    std::filesystem::create_directories(dir);
    auto d = std::make_unique<DaemonProcess>(
        dir, domain_,
        "version: 1\ndds:\n  service_id: " + name + "\n  scenes: [\"" + own + "\", \"" + backed +
            "\"]\n  shard_strengths: {\"" + own + "\": 20, \"" + backed +
            "\": 10}\n  status_period_s: 0.2\n  cyclonedds_config: '" + network_config() +
            "'\nthreads: 1\nlog:\n  timing_summary_period_s: 0\n");
    d->set_command_prefix(lan_->exec_prefix(host));
    return d;
  }
  static std::string scene_name(int shard, int k) {
    return "shard" + std::to_string(shard) + "-" + std::to_string(k);
  }

  std::uint32_t domain_ = private_domain();
  std::unique_ptr<VirtualLan> lan_;
  std::filesystem::path dir_;
  std::vector<std::unique_ptr<DaemonProcess>> daemons_;  // host i's: shard i's primary
};

TEST_F(LoadSplitTest, EverySceneHasOneOwnerWhileHostsAreKilledAndRestartedInTurn) {
  AnswerObserver observer(domain_, "shard");
  ASSERT_EQ(observer.error(), "");
  const client::Mesh a = box_mesh(2, {-0.5, -0.5, -0.5}, {0.5, 0.5, 0.5});
  const client::Mesh b = box_mesh(2, {0.3, -0.4, -0.4}, {1.3, 0.6, 0.6});
  std::vector<std::unique_ptr<client::Client>> clients;
  for (int shard = 0; shard < kShards; ++shard)
    for (int k = 0; k < kScenesPerShard; ++k) {
      clients.push_back(client::Client::connect(domain_, scene_name(shard, k)));
      clients.back()->register_object("a", a, {});
      clients.back()->register_object("b", b, {});
    }
  for (auto& c : clients) ASSERT_TRUE(c->wait_registered("b", 20s).ok);
  // Every daemon built its shard's objects and every answer writer is matched.
  for (int shard = 0; shard < kShards; ++shard)
    for (int k = 0; k < kScenesPerShard; ++k)
      for (const char role : {'p', 's'}) {
        auto& d = daemons_[static_cast<std::size_t>(host_of(role, shard))];
        ASSERT_TRUE(d->wait_for_log(scene_name(shard, k) + "/b: registered", 20s)) << d->log_text();
      }
  ASSERT_TRUE(observer.wait_for_writers(2 * kShards, 20s));

  std::atomic<bool> stop{false};
  std::thread stream([&] {
    std::vector<std::vector<double>> pa;
    std::vector<std::vector<double>> pb;
    for (int k = 0; k < 10; ++k) {
      pa.push_back(translated(a, {0.0, 0.0, 0.002 * k}));
      pb.push_back(translated(b, {-0.003 * k, 0.0, 0.0}));
    }
    const auto t0 = Clock::now();
    for (std::int64_t f = 0; !stop; ++f) {
      std::this_thread::sleep_until(t0 + f * 50ms);
      const auto k = static_cast<std::size_t>(f % 10);
      for (auto& c : clients) c->publish_states(f, {{"a", pa[k]}, {"b", pb[k]}});
    }
  });
  // Polls the observer until `done` holds or `timeout`.
  const auto poll_until = [&](const std::function<bool()>& done,
                              std::chrono::milliseconds timeout) {
    const auto deadline = Clock::now() + timeout;
    for (;;) {
      observer.poll();
      if (done()) return true;
      if (Clock::now() >= deadline) return false;
      std::this_thread::sleep_for(5ms);
    }
  };
  // True when the newest answer of every scene of `shard` came from `service`.
  const auto owned_by = [&](int shard, const std::string& service) {
    std::map<std::string, std::string> newest;
    for (const auto& ans : observer.answers()) newest[ans.scene] = ans.service;
    for (int k = 0; k < kScenesPerShard; ++k) {
      const auto it = newest.find(scene_name(shard, k));
      if (it == newest.end() || it->second != service) return false;
    }
    return true;
  };
  bool ok = poll_until(
      [&] {
        for (int shard = 0; shard < kShards; ++shard)
          if (!owned_by(shard, role_name('p', shard))) return false;
        return true;
      },
      20s);
  EXPECT_TRUE(ok) << "the primaries never owned their shards";
  const std::size_t from = observer.answers().size();  // checks start here
  for (int host = 0; ok && host < kShards; ++host) {
    // Shard `host` loses its primary; shard host - 1 its standby.
    daemons_[static_cast<std::size_t>(host)]->kill_hard();
    ok = poll_until([&] { return owned_by(host, role_name('s', host)); }, 10s);
    EXPECT_TRUE(ok) << "shard " << host << " never moved to its standby";
    ok = ok && daemons_[static_cast<std::size_t>(host)]->start();
    EXPECT_TRUE(ok) << "host " << host << "'s daemon did not restart";
    ok = ok && poll_until([&] { return owned_by(host, role_name('p', host)); }, 20s);
    EXPECT_TRUE(ok) << "shard " << host << "'s primary never took over again";
    poll_until([] { return false; }, 300ms);
  }
  stop = true;
  stream.join();
  observer.poll();
  ASSERT_EQ(observer.error(), "");

  // Per instance (scene, object), in arrival order: the owners, and the longest time
  // without an answer.
  std::map<std::string, std::vector<const AnswerObserver::Answer*>> by_scene;
  const auto& answers = observer.answers();
  for (std::size_t i = from; i < answers.size(); ++i)
    by_scene[answers[i].scene + "/" + answers[i].object].push_back(&answers[i]);
  ASSERT_EQ(by_scene.size(), static_cast<std::size_t>(2 * kShards * kScenesPerShard));
  double worst_gap_ms = 0.0;
  for (const auto& [scene, list] : by_scene) {
    const int shard = scene[5] - '0';
    const std::string primary = role_name('p', shard);
    const std::string standby = role_name('s', shard);
    std::vector<std::string> owners;
    dds_time_t last = list.front()->written;
    double gap_ms = 0.0;
    for (const auto* ans : list) {
      if (owners.empty() || owners.back() != ans->service) owners.push_back(ans->service);
      gap_ms = std::max(gap_ms, static_cast<double>(ans->written - last) / 1e6);
      last = std::max(last, ans->written);
    }
    worst_gap_ms = std::max(worst_gap_ms, gap_ms);
    // The primary's answers written before the kill may still arrive after the checks began.
    if (!owners.empty() && owners.front() == primary) owners.erase(owners.begin());
    if (test::kSanitized) {
      // Under a sanitizer the 4 daemons share 2 cores at a fraction of their speed, and a
      // starved primary's 1 s lease can lapse: ownership then passes to the standby and
      // back more than once (seen once in a CI run: standby, primary, standby, primary).
      // Still: only the scene's two hosts answer it, the standby first, the primary last.
      ASSERT_FALSE(owners.empty()) << scene;
      for (const std::string& owner : owners)
        EXPECT_TRUE(owner == standby || owner == primary) << scene << ": answered by " << owner;
      EXPECT_EQ(owners.front(), standby) << scene;
      EXPECT_EQ(owners.back(), primary) << scene;
    } else {
      EXPECT_EQ(owners, (std::vector<std::string>{standby, primary})) << scene;
    }
    // The 1 s lease, then the next frame and its computation: 0.5 s of slack in Release,
    // 4x that under a sanitizer (then 8 daemons on 2 cores under ASan: 1,662 ms seen once).
    EXPECT_LT(gap_ms, 1000.0 + 500.0 * test::kTimeSlack)
        << scene << ": longest time without an answer";
  }
  std::printf(
      "load split: %d scenes, %zu answers while 4 hosts were killed and restarted in "
      "turn; longest time a scene went without an answer: %.0f ms\n",
      kShards * kScenesPerShard, answers.size() - from, worst_gap_ms);
}

}  // namespace
}  // namespace tc::itest
