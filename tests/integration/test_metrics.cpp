// The daemon's Prometheus endpoint (metrics.listen, docs/DEPLOYMENT.md "Metrics"), scraped
// over HTTP with a plain socket while a client streams: frames answered, objects,
// rejected states by code, a scene's series leaving with it, the ownership of a scene's
// answers moving to the standby when the primary dies, and the startup errors.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <csignal>
#include <fstream>
#include <optional>
#include <regex>
#include <thread>

#include "daemon_process.hpp"
#include "metrics_scrape.hpp"
#include "scenes.hpp"
#include "tetcollide/client.hpp"

namespace tc::itest {
namespace {

using namespace std::chrono_literals;
using client::Client;
using Clock = std::chrono::steady_clock;

std::string config_with_metrics(const std::string& extra_dds = "") {
  return "version: 1\ndds:\n  status_period_s: 0.2\n" + extra_dds +
         "frames:\n  assembly_wait_ms: 50\nlog:\n  level: info\n  timing_summary_period_s: "
         "0\nmetrics:\n  listen: 127.0.0.1:0\n";
}

/// The port of the daemon's "metrics: serving http://127.0.0.1:PORT/metrics" line.
int metrics_port(const DaemonProcess& d) {
  const std::regex line(R"(metrics: serving http://127\.0\.0\.1:([0-9]+)/metrics)");
  std::smatch m;
  const std::string log = d.log_text();
  return std::regex_search(log, m, line) ? std::stoi(m[1].str()) : 0;
}

using tc::test::scrape_metrics;

std::optional<double> sample(const std::string& text, const std::string& series) {
  return tc::test::metric_sample(text, series);
}

/// Scrapes until `series` has the value `want` (absent: nullopt) or `timeout` passed;
/// the last value seen. The daemon counts a frame after it wrote the answers, so a
/// client holding the answer may scrape a moment before the count.
std::optional<double> wait_value(int port, const std::string& series, std::optional<double> want,
                                 std::chrono::milliseconds timeout = 10s) {
  const auto deadline = Clock::now() + timeout;
  std::optional<double> seen;
  while (true) {
    if (const auto text = scrape_metrics(port)) seen = sample(*text, series);
    if (seen == want || Clock::now() > deadline) return seen;
    std::this_thread::sleep_for(20ms);
  }
}

class MetricsTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = make_temp_dir("itest-metrics"); }
  void TearDown() override {
    for (auto* d : {primary_.get(), standby_.get()})
      if (HasFailure() && d != nullptr) std::cerr << "---- daemon log ----\n" << d->log_text();
    primary_.reset();
    standby_.reset();
    std::filesystem::remove_all(dir_);
  }
  std::unique_ptr<Client> connect(const std::string& scene) {
    client::Options o;
    o.domain = domain_;
    o.scene = scene;
    auto c = Client::connect(o);
    EXPECT_TRUE(c->wait_for_service(10s)) << "no READY service on domain " << domain_;
    return c;
  }

  std::uint32_t domain_ = private_domain();
  std::filesystem::path dir_;
  std::unique_ptr<DaemonProcess> primary_;
  std::unique_ptr<DaemonProcess> standby_;
};

TEST_F(MetricsTest, ScrapedValuesFollowFramesObjectsAndRejections) {
  primary_ = std::make_unique<DaemonProcess>(dir_, domain_, config_with_metrics());
  ASSERT_TRUE(primary_->start());
  const int port = metrics_port(*primary_);
  ASSERT_GT(port, 0) << "no 'metrics: serving' line";
  const auto before = scrape_metrics(port);
  ASSERT_TRUE(before) << "GET /metrics failed";
  for (const char* name :
       {"process_resident_memory_bytes", "process_cpu_seconds_total", "process_open_fds",
        "process_start_time_seconds", "tetcollide_heap_in_use_bytes"})
    EXPECT_TRUE(sample(*before, name)) << name << " missing in:\n" << *before;
  EXPECT_EQ(before->find(R"(scene="m")"), std::string::npos);

  auto c = connect("m");
  TwoBoxes s;
  ASSERT_TRUE(s.register_with(*c));
  constexpr std::int64_t kFrames = 20;
  std::int64_t answered = 0;
  for (std::int64_t f = 0; f < kFrames; ++f) {
    const auto pa = translated(s.a, {0.0, 0.0, 0.001 * static_cast<double>(f)});
    client::ObjectState sb{"b", s.b.rest_positions};
    if (f == 7) sb.topology_version = 77;  // stale: rejected with stale_version
    const std::vector<client::ObjectState> states{{"a", pa}, sb};
    c->publish_states(f, states);
    const auto forces = c->wait_forces(f, 5s);
    ASSERT_TRUE(forces && forces->frame == f) << "frame " << f << " not answered";
    ++answered;
  }
  EXPECT_EQ(wait_value(port, R"(tetcollide_frames_total{scene="m"})", answered), answered);
  const auto text = scrape_metrics(port);
  ASSERT_TRUE(text);
  EXPECT_EQ(sample(*text, R"(tetcollide_frame_compute_seconds_count{scene="m"})"), answered);
  EXPECT_EQ(sample(*text, R"(tetcollide_frame_compute_seconds_bucket{scene="m",le="+Inf"})"),
            answered);
  EXPECT_GT(sample(*text, R"(tetcollide_frame_compute_seconds_sum{scene="m"})").value_or(0), 0.0);
  EXPECT_EQ(sample(*text, R"(tetcollide_frame_latency_seconds_count{scene="m"})"), answered);
  EXPECT_EQ(sample(*text, R"(tetcollide_objects{scene="m"})"), 2.0);
  EXPECT_GT(sample(*text, R"(tetcollide_contacts{scene="m"})").value_or(0), 0.0);
  EXPECT_EQ(sample(*text, R"(tetcollide_rejected_states_total{code="stale_version",scene="m"})"),
            1.0)
      << *text;
  EXPECT_EQ(sample(*text, R"(tetcollide_dropped_frames_total{scene="m"})"), 0.0);
  // The only daemon: clients take its answers, nobody else's ever.
  EXPECT_EQ(wait_value(port, R"(tetcollide_answer_owner{scene="m"})", 1.0), 1.0);
  EXPECT_EQ(sample(*scrape_metrics(port), R"(tetcollide_ownership_changes_total{scene="m"})"), 0.0);

  // A state for an object nobody registered.
  const auto pa = translated(s.a, {0.0, 0.0, 0.0});
  const auto ghost = s.b.rest_positions;
  c->publish_states(kFrames, {{"a", pa}, {"b", s.b.rest_positions}, {"ghost", ghost}});
  ASSERT_TRUE(c->wait_forces(kFrames, 5s));
  EXPECT_EQ(
      wait_value(port, R"(tetcollide_rejected_states_total{code="unknown_object",scene="m"})", 1.0),
      1.0);

  // Removing the objects: the gauge follows, and the scene's series leave with it.
  c->remove_object("b");
  EXPECT_EQ(wait_value(port, R"(tetcollide_objects{scene="m"})", 1.0), 1.0);
  c->remove_object("a");
  EXPECT_EQ(wait_value(port, R"(tetcollide_objects{scene="m"})", std::nullopt), std::nullopt);
  EXPECT_EQ(scrape_metrics(port)->find(R"(tetcollide_frames_total{scene="m"})"), std::string::npos);
}

TEST_F(MetricsTest, TheStandbyCountsTheFailoverWhenThePrimaryDies) {
  const std::string lease = "  answer_lease_ms: 100\n";
  std::filesystem::create_directories(dir_ / "primary");
  std::filesystem::create_directories(dir_ / "standby");
  primary_ = std::make_unique<DaemonProcess>(
      dir_ / "primary", domain_, config_with_metrics(lease + "  ownership_strength: 20\n"));
  standby_ = std::make_unique<DaemonProcess>(
      dir_ / "standby", domain_, config_with_metrics(lease + "  ownership_strength: 10\n"));
  ASSERT_TRUE(primary_->start());
  ASSERT_TRUE(standby_->start());
  const int primary_port = metrics_port(*primary_);
  const int standby_port = metrics_port(*standby_);
  ASSERT_GT(primary_port, 0);
  ASSERT_GT(standby_port, 0);

  auto c = connect("f");
  TwoBoxes s;
  ASSERT_TRUE(s.register_with(*c));
  std::int64_t f = 0;
  const auto stream = [&](std::int64_t frames) {
    for (const std::int64_t end = f + frames; f < end; ++f) {
      const auto pa = translated(s.a, {0.0, 0.0, 0.001 * static_cast<double>(f % 50)});
      c->publish_states(f, {{"a", pa}, {"b", s.b.rest_positions}});
      c->wait_forces(f, 5s);
    }
  };
  stream(10);
  EXPECT_EQ(wait_value(primary_port, R"(tetcollide_answer_owner{scene="f"})", 1.0), 1.0);
  EXPECT_EQ(wait_value(standby_port, R"(tetcollide_answer_owner{scene="f"})", 0.0), 0.0);
  // The standby computes frames too (all of them, or fewer when a newer frame supersedes
  // one while it is busy); only the primary's answers reach the client.
  std::optional<double> standby_frames;
  for (const auto until = Clock::now() + 10s;
       standby_frames.value_or(0) < 1 && Clock::now() < until; std::this_thread::sleep_for(20ms))
    if (const auto text = scrape_metrics(standby_port))
      standby_frames = sample(*text, R"(tetcollide_frames_total{scene="f"})");
  EXPECT_GE(standby_frames.value_or(0), 1.0);
  // The standby's answer to the scene's first frame may reach a reader before the
  // primary's (then the primary takes over at once): a change counted before the kill.
  const auto changes_before =
      sample(*scrape_metrics(standby_port), R"(tetcollide_ownership_changes_total{scene="f"})");
  ASSERT_TRUE(changes_before);
  EXPECT_LE(*changes_before, 1.0);

  primary_->kill_hard();
  // Frames until the standby's answers are the ones taken (its writer's lease: 100 ms).
  const auto deadline = Clock::now() + 20s;
  std::optional<double> owner;
  while (owner != 1.0 && Clock::now() < deadline) {
    stream(1);
    if (const auto text = scrape_metrics(standby_port))
      owner = sample(*text, R"(tetcollide_answer_owner{scene="f"})");
  }
  EXPECT_EQ(owner, 1.0) << "the standby never became the owner of scene f";
  EXPECT_EQ(
      sample(*scrape_metrics(standby_port), R"(tetcollide_ownership_changes_total{scene="f"})"),
      *changes_before + 1.0);
}

TEST(MetricsStartup, ABadAddressOrABusyPortIsAClearError) {
  const std::string daemon = program_from_env("TC_DAEMON");
  const auto dir = make_temp_dir("itest-metrics-cli");
  const auto bad = dir / "bad.yaml";
  std::ofstream(bad) << "version: 1\nmetrics:\n  listen: metrics.example:9464\n";
  auto r = run_program({daemon, "--config", bad.string()}, 20s);
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_NE(r.err.find("bad.yaml:3:11: metrics.listen: 'metrics.example:9464'"), std::string::npos)
      << r.err;
  // A port someone else holds.
  const int holder = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(bind(holder, reinterpret_cast<const sockaddr*>(&addr), sizeof addr), 0);
  ASSERT_EQ(listen(holder, 1), 0);
  socklen_t len = sizeof addr;
  getsockname(holder, reinterpret_cast<sockaddr*>(&addr), &len);
  const auto busy = dir / "busy.yaml";
  std::ofstream(busy) << "version: 1\nmetrics:\n  listen: 127.0.0.1:" << ntohs(addr.sin_port)
                      << "\n";
  r = run_program({daemon, "--config", busy.string(), "--domain", std::to_string(private_domain())},
                  20s);
  close(holder);
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("metrics.listen: cannot serve on 127.0.0.1:"), std::string::npos) << r.err;
  // An address other than loopback is served, with a warning.
  {
    DaemonProcess open(dir, private_domain(), "version: 1\nmetrics:\n  listen: 0.0.0.0:0\n");
    ASSERT_TRUE(open.start()) << open.log_text();
    EXPECT_NE(open.log_text().find("[warning] metrics: serving http://0.0.0.0:"), std::string::npos)
        << open.log_text();
    EXPECT_NE(open.log_text().find("not loopback"), std::string::npos);
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace tc::itest
