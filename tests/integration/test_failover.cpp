// Shards with hot standbys (issue 15): a primary (ownership strength 20) and a standby
// (10) serve the same scenes on two hosts, the simulator runs on a third (VirtualLan with
// a bridge). Both daemons compute every frame; the client sees only the answers of the
// strongest live one (ContactForces and FrameStats have EXCLUSIVE ownership). SIGKILL the
// primary: the standby's answers reach the client once the primary's liveliness lease
// (1 s) expired; a returning primary takes over again. Needs root; skips with the
// reason elsewhere. Label: integration, hosts.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

#include "daemon_process.hpp"
#include "protocol.hpp"
#include "recording.hpp"
#include "replayer.hpp"
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
  };

  AnswerObserver(std::uint32_t domain, std::string scene) : scene_(std::move(scene)) {
    participant_ = dds_create_participant(domain, nullptr, nullptr);
    if (participant_ < 0) {
      error_ = "dds_create_participant: " + protocol::dds_error(participant_);
      return;
    }
    forces_ = make_reader(protocol::Topic::kForces, 0);
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
          if (protocol::bounded_view(s.scene) != scene_) return;
          Answer a{std::string(protocol::bounded_view(s.object)), s.frame, {}};
          if (const auto key = participant_of(forces_, info.publication_handle)) {
            const auto it = services_.find(*key);
            if (it != services_.end()) a.service = it->second;
          }
          answers_.push_back(std::move(a));
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
      if (n > 0) dds_return_loan(reader, samples, n);
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
  const char* recordings = std::getenv("TC_RECORDINGS");
  ASSERT_NE(recordings, nullptr);
  const auto records =
      replay::read_recording(std::filesystem::path(recordings) / "two_boxes.jsonl");
  ASSERT_TRUE(records) << records.error().message;
  AnswerObserver observer(domain_, "two_boxes");
  ASSERT_EQ(observer.error(), "");
  ASSERT_TRUE(observer.wait_for_writers(2, 20s)) << "the daemons' answer writers never matched";

  replay::ReplayOptions o;
  o.domain = domain_;
  o.rate = 0.0;
  o.check = true;
  o.frame_timeout = 30s;
  o.resend_after = 300ms;
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

}  // namespace
}  // namespace tc::itest
