// The real tetcollided under a Type=notify unit, without systemd: the test opens a fake
// notification socket (tests/support/notify_socket.hpp), passes it in NOTIFY_SOCKET with
// a watchdog period in WATCHDOG_USEC, and checks what systemd would see: READY=1 once
// the daemon is ready (its "tetcollided ready" line is already logged and a client
// finds the service), STATUS= lines with the scenes, objects and frames/s while it
// serves, WATCHDOG=1 at least every period, STOPPING=1 only after SIGTERM.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <csignal>
#include <cstdlib>
#include <fstream>
#include <regex>
#include <sstream>
#include <thread>

#include "daemon_process.hpp"
#include "notify_socket.hpp"
#include "scenes.hpp"
#include "tetcollide/client.hpp"

namespace tc::itest {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

const char* kConfig = R"(version: 1
dds:
  status_period_s: 0.2
frames:
  assembly_wait_ms: 50
log:
  level: info
  timing_summary_period_s: 0
)";

class SystemdNotifyTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = make_temp_dir("itest-systemd");
    std::ofstream(dir_ / "tetcollided.yaml") << kConfig;
  }
  void TearDown() override {
    unsetenv("NOTIFY_SOCKET");
    unsetenv("WATCHDOG_USEC");
    if (HasFailure()) std::cerr << "---- daemon log ----\n" << log_text();
    daemon_.stop(SIGKILL);  // no-op when stopped already
    std::filesystem::remove_all(dir_);
  }
  /// Starts the daemon without waiting for anything (the test waits for READY=1).
  void start_daemon() {
    const std::string daemon = program_from_env("TC_DAEMON");
    ASSERT_FALSE(daemon.empty());
    ASSERT_TRUE(daemon_.start({daemon, "--config", (dir_ / "tetcollided.yaml").string(), "--domain",
                               std::to_string(domain_)},
                              dir_ / "daemon.out", dir_ / "daemon.log"));
  }
  [[nodiscard]] std::string log_text() const {
    std::ifstream in(dir_ / "daemon.log");
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
  }

  std::uint32_t domain_ = private_domain();
  std::filesystem::path dir_;
  ChildProcess daemon_;
};

TEST_F(SystemdNotifyTest, ReadyAfterTheReadyLineThenStatusAndWatchdogThenStoppingOnSigterm) {
  test::FakeNotifySocket socket;
  setenv("NOTIFY_SOCKET", socket.address().c_str(), 1);
  setenv("WATCHDOG_USEC", "1000000", 1);  // WatchdogSec=1: a ping every 0.5 s
  start_daemon();

  const auto ready = socket.wait_for("READY=1", 20s);
  ASSERT_TRUE(ready) << "no READY=1";
  // Readiness comes after the readers and writers are up, never before: the log line
  // is already written and nothing was sent before it.
  EXPECT_NE(log_text().find("tetcollided ready"), std::string::npos);
  EXPECT_EQ(socket.messages().size(), 1u);
  EXPECT_EQ(test::assignment_value(*ready, "STATUS"), "ready: 0 scenes, 0 objects, 0.0 frames/s");
  std::vector<Clock::time_point> pings;

  // A client finds the service at once and streams two overlapping boxes.
  client::Options o;
  o.domain = domain_;
  o.scene = "notify";
  auto c = client::Client::connect(o);
  ASSERT_TRUE(c->wait_for_service(5s));
  const auto a = box_mesh(2, {-0.5, -0.5, -0.5}, {0.5, 0.5, 0.5});
  const auto b = box_mesh(2, {0.3, -0.4, -0.4}, {1.3, 0.6, 0.6});
  c->register_object("a", a, {});
  c->register_object("b", b, {});
  ASSERT_TRUE(c->wait_registered("a", 10s).ok);
  ASSERT_TRUE(c->wait_registered("b", 10s).ok);

  // STATUS= lines while serving; every notification is read as it comes so the
  // watchdog pings get their arrival times.
  std::optional<std::string> serving;
  const std::regex serving_line(R"(1 scene, 2 objects, ([0-9]+\.[0-9]) frames/s)");
  const auto deadline = Clock::now() + 15s;
  std::int64_t frame = 0;
  while (Clock::now() < deadline && (!serving || pings.size() < 3)) {
    const auto pa = translated(a, {0.0, 0.0, 0.001 * static_cast<double>(frame)});
    c->publish_states(frame, {{"a", pa}, {"b", b.rest_positions}});
    EXPECT_TRUE(c->wait_forces(frame, 5s)) << "frame " << frame;
    ++frame;
    while (auto m = socket.receive(0ms)) {
      if (test::has_assignment(*m, "WATCHDOG=1")) pings.push_back(Clock::now());
      const auto status = test::assignment_value(*m, "STATUS");
      std::smatch rate;
      if (status && !serving && std::regex_match(*status, rate, serving_line) &&
          std::stod(rate[1].str()) > 0.0)
        serving = status;
    }
    std::this_thread::sleep_for(10ms);
  }
  ASSERT_TRUE(serving) << "no STATUS= with 1 scene, 2 objects and frames/s > 0";
  ASSERT_GE(pings.size(), 3u);
  for (std::size_t i = 1; i < pings.size(); ++i)
    EXPECT_LT(pings[i] - pings[i - 1], 1000ms) << "watchdog gap before ping " << i;
  for (const auto& m : socket.messages()) {
    EXPECT_FALSE(test::has_assignment(m, "STOPPING=1")) << "STOPPING=1 before SIGTERM";
    EXPECT_EQ(test::has_assignment(m, "READY=1"), &m == &socket.messages().front());
  }
  const std::size_t before_sigterm = socket.messages().size();

  EXPECT_EQ(daemon_.stop(SIGTERM), 0);
  const auto stopping = socket.wait_for("STOPPING=1", 5s);  // queued before the exit
  ASSERT_TRUE(stopping) << "no STOPPING=1 after SIGTERM";
  EXPECT_GT(socket.messages().size(), before_sigterm);
  const std::string log = log_text();
  EXPECT_NE(log.find("received SIGTERM"), std::string::npos);
  EXPECT_NE(log.find("tetcollided stopped"), std::string::npos);
  EXPECT_EQ(log.find("sd_notify"), std::string::npos) << "a notification failed";
}

// A NOTIFY_SOCKET nobody listens on (systemd gone, a stale variable) changes nothing
// but one warning in the log.
TEST_F(SystemdNotifyTest, AnUnreachableNotifySocketIsNotFatal) {
  std::string address;
  {
    test::FakeNotifySocket closed;
    address = closed.address();
  }
  setenv("NOTIFY_SOCKET", address.c_str(), 1);
  start_daemon();
  ASSERT_TRUE(wait_for_file_text(dir_ / "daemon.log", "tetcollided ready", 20s));
  client::Options o;
  o.domain = domain_;
  o.scene = "unreachable";
  auto c = client::Client::connect(o);
  EXPECT_TRUE(c->wait_for_service(5s));
  // Each heartbeat sample goes with a STATUS= send: wait for three of them.
  int heartbeats = 0;
  const auto deadline = Clock::now() + 10s;
  while (heartbeats < 3 && Clock::now() < deadline) {
    for (const auto& e : c->take_status_events())
      if (e.kind == client::StatusEvent::Kind::kHeartbeat) ++heartbeats;
    c->poll(50ms);
  }
  EXPECT_GE(heartbeats, 3);
  EXPECT_EQ(daemon_.stop(SIGTERM), 0);
  const std::string log = log_text();
  const auto first = log.find("sd_notify to NOTIFY_SOCKET failed");
  ASSERT_NE(first, std::string::npos) << log;
  EXPECT_EQ(log.find("sd_notify to NOTIFY_SOCKET failed", first + 1), std::string::npos)
      << "logged more than once";
  EXPECT_NE(log.find("tetcollided stopped"), std::string::npos);
}

}  // namespace
}  // namespace tc::itest
