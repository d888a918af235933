// service/daemon/systemd_notify: the messages a Type=notify unit gets, sent to a fake
// notification socket; the watchdog schedule with a fake clock; nothing at all without
// NOTIFY_SOCKET.
#include "systemd_notify.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <string>

#include "notify_socket.hpp"

namespace tc::daemon {
namespace {

using std::chrono::milliseconds;

/// Sets the notification variables for one test and restores them afterwards.
class SystemdNotifierTest : public ::testing::Test {
 protected:
  SystemdNotifierTest() {
    for (const char* v : kVariables) {
      const char* old = std::getenv(v);
      saved_.emplace_back(v, old ? std::optional<std::string>(old) : std::nullopt);
      unsetenv(v);
    }
  }
  ~SystemdNotifierTest() override {
    for (const auto& [name, value] : saved_) {
      if (value)
        setenv(name.c_str(), value->c_str(), 1);
      else
        unsetenv(name.c_str());
    }
  }
  static void set(const char* name, const std::string& value) { setenv(name, value.c_str(), 1); }

  static constexpr const char* kVariables[] = {"NOTIFY_SOCKET", "WATCHDOG_USEC", "WATCHDOG_PID"};
  std::vector<std::pair<std::string, std::optional<std::string>>> saved_;
  Clock::time_point t0{std::chrono::seconds(500)};
};

TEST(SystemdStatusLine, SaysScenesObjectsAndFramesPerSecond) {
  EXPECT_EQ(status_line(0, 0, 0.0), "0 scenes, 0 objects, 0.0 frames/s");
  EXPECT_EQ(status_line(1, 1, 59.84), "1 scene, 1 object, 59.8 frames/s");
  EXPECT_EQ(status_line(3, 12, 240.0), "3 scenes, 12 objects, 240.0 frames/s");
  EXPECT_EQ(status_line(2, 2, -1.0), "2 scenes, 2 objects, 0.0 frames/s");
}

TEST_F(SystemdNotifierTest, WithoutNotifySocketNothingIsSentAndNoWatchdogIsDue) {
  test::FakeNotifySocket socket;  // exists, but nobody told the notifier about it
  SystemdNotifier n(t0);
  EXPECT_FALSE(n.enabled());
  EXPECT_FALSE(n.next_watchdog());
  n.ready("ready");
  n.status("1 scene");
  n.watchdog(t0 + std::chrono::hours(1));
  n.stopping("stopping");
  EXPECT_FALSE(socket.receive(milliseconds(100)));
}

TEST_F(SystemdNotifierTest, ReadyStatusAndStoppingReachTheSocketInOrder) {
  test::FakeNotifySocket socket;
  set("NOTIFY_SOCKET", socket.address());
  SystemdNotifier n(t0);
  EXPECT_TRUE(n.enabled());
  n.ready("ready: 0 scenes");
  n.status("2 scenes, 3 objects, 60.0 frames/s");
  n.status("two\nlines");  // one line: no way to smuggle in another assignment
  n.stopping("stopping");
  const auto ready = socket.receive(milliseconds(2000));
  ASSERT_TRUE(ready);
  EXPECT_EQ(*ready, "READY=1\nSTATUS=ready: 0 scenes");
  EXPECT_EQ(socket.receive(milliseconds(2000)), "STATUS=2 scenes, 3 objects, 60.0 frames/s");
  EXPECT_EQ(socket.receive(milliseconds(2000)), "STATUS=two lines");
  const auto stopping = socket.receive(milliseconds(2000));
  ASSERT_TRUE(stopping);
  EXPECT_TRUE(test::has_assignment(*stopping, "STOPPING=1"));
  EXPECT_EQ(test::assignment_value(*stopping, "STATUS"), "stopping");
  EXPECT_FALSE(socket.receive(milliseconds(50)));
}

TEST_F(SystemdNotifierTest, WatchdogPingsEveryHalfPeriod) {
  test::FakeNotifySocket socket;
  set("NOTIFY_SOCKET", socket.address());
  set("WATCHDOG_USEC", "400000");  // WatchdogSec=0.4s
  set("WATCHDOG_PID", std::to_string(getpid()));
  SystemdNotifier n(t0);
  ASSERT_TRUE(n.watchdog_interval());
  EXPECT_EQ(*n.watchdog_interval(), milliseconds(200));
  ASSERT_TRUE(n.next_watchdog());
  EXPECT_EQ(*n.next_watchdog(), t0 + milliseconds(200));
  n.watchdog(t0 + milliseconds(199));
  EXPECT_FALSE(socket.receive(milliseconds(50)));
  n.watchdog(t0 + milliseconds(250));
  EXPECT_EQ(socket.receive(milliseconds(2000)), "WATCHDOG=1");
  EXPECT_EQ(*n.next_watchdog(), t0 + milliseconds(450));  // from the ping, not the schedule
  n.watchdog(t0 + milliseconds(300));
  EXPECT_FALSE(socket.receive(milliseconds(50)));
  n.watchdog(t0 + milliseconds(450));
  EXPECT_EQ(socket.receive(milliseconds(2000)), "WATCHDOG=1");
}

TEST_F(SystemdNotifierTest, AWatchdogMeantForAnotherProcessIsIgnored) {
  test::FakeNotifySocket socket;
  set("NOTIFY_SOCKET", socket.address());
  set("WATCHDOG_USEC", "400000");
  set("WATCHDOG_PID", std::to_string(getpid() + 1));
  SystemdNotifier n(t0);
  EXPECT_FALSE(n.watchdog_interval());
  n.watchdog(t0 + std::chrono::hours(1));
  EXPECT_FALSE(socket.receive(milliseconds(100)));
}

TEST_F(SystemdNotifierTest, AnUnreachableSocketIsNotAnError) {
  std::string address;
  {
    test::FakeNotifySocket gone;
    address = gone.address();
  }
  set("NOTIFY_SOCKET", address);
  SystemdNotifier n(t0);
  EXPECT_TRUE(n.enabled());
  n.ready("ready");  // ECONNREFUSED: logged once, not thrown
  n.status("still running");
  n.stopping("stopping");
}

}  // namespace
}  // namespace tc::daemon
