// DDS Security (config/security/): the real tetcollided with the secure profile, a test
// PKI made by config/security/make_test_pki.sh in a temporary directory for each test.
// Participants with another identity (or none) run in a second process
// (itest_security_peer) because Cyclone DDS allows one configuration per domain and
// process. Labels: integration, security. docs/RELIABILITY.md, "DDS Security".
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <linux/if_ether.h>
#include <linux/if_packet.h>
#include <net/if.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>

#include "daemon_process.hpp"
#include "scenes.hpp"
#include "tetcollide/client.hpp"

namespace tc::itest {
namespace {

using namespace std::chrono_literals;
using client::Client;

/// "key=value" lines of a peer's stdout.
std::map<std::string, std::string> parse_peer(const std::filesystem::path& out) {
  std::ifstream in(out);
  std::map<std::string, std::string> kv;
  std::string line;
  while (std::getline(in, line))
    if (const auto eq = line.find('='); eq != std::string::npos)
      kv[line.substr(0, eq)] = line.substr(eq + 1);
  return kv;
}

std::string slurp(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Captures every packet on the loopback interface (AF_PACKET) into memory while alive.
/// Needs CAP_NET_RAW: root, or the user namespace run_isolated.sh creates.
class LoopbackCapture {
 public:
  LoopbackCapture() {
    fd_ = socket(AF_PACKET, SOCK_RAW, htons(ETH_P_ALL));
    if (fd_ < 0) return;
    sockaddr_ll addr{};
    addr.sll_family = AF_PACKET;
    addr.sll_protocol = htons(ETH_P_ALL);
    addr.sll_ifindex = static_cast<int>(if_nametoindex("lo"));
    timeval tv{0, 50000};
    if (addr.sll_ifindex == 0 || bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 ||
        setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv) != 0) {
      close(fd_);
      fd_ = -1;
      return;
    }
    thread_ = std::thread([this] {
      std::vector<char> buf(1 << 17);
      while (!stop_) {
        const ssize_t n = recv(fd_, buf.data(), buf.size(), 0);
        if (n <= 0) continue;
        std::lock_guard lock(mutex_);
        ++packets_;
        if (bytes_.size() < (std::size_t{256} << 20))
          bytes_.append(buf.data(), static_cast<std::size_t>(n));
      }
    });
  }
  ~LoopbackCapture() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
    if (fd_ >= 0) close(fd_);
  }
  LoopbackCapture(const LoopbackCapture&) = delete;
  LoopbackCapture& operator=(const LoopbackCapture&) = delete;
  [[nodiscard]] bool ok() const { return fd_ >= 0; }
  [[nodiscard]] bool contains(const std::string& text) {
    std::lock_guard lock(mutex_);
    return bytes_.find(text) != std::string::npos;
  }
  void clear() {
    std::lock_guard lock(mutex_);
    bytes_.clear();
  }
  [[nodiscard]] std::size_t packets() {
    std::lock_guard lock(mutex_);
    return packets_;
  }

 private:
  int fd_ = -1;
  std::atomic<bool> stop_{false};
  std::thread thread_;
  std::mutex mutex_;
  std::string bytes_;
  std::size_t packets_ = 0;
};

class SecurityTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = make_temp_dir("itest-security");
    pki_ = dir_ / "pki";
    const std::string script = program_from_env("TC_SECURITY_PKI_SCRIPT");
    ASSERT_FALSE(script.empty());
    const RunResult pki = run_program({"/bin/sh", script, pki_.string()}, 60s);
    ASSERT_EQ(pki.exit_code, 0) << pki.out << pki.err;
    const char* uri = std::getenv("CYCLONEDDS_URI");
    ASSERT_NE(uri, nullptr) << "CYCLONEDDS_URI (the loopback config) is not set";
    network_ = uri;
    daemon_ = std::make_unique<DaemonProcess>(dir_, domain_, daemon_config(profile("service")));
    ASSERT_TRUE(daemon_->start()) << daemon_->log_text();
  }
  void TearDown() override {
    if (HasFailure() && daemon_) std::cerr << "---- daemon log ----\n" << daemon_->log_text();
    daemon_.reset();
    std::filesystem::remove_all(dir_);
  }

  static std::string daemon_config(const std::string& cyclonedds_config) {
    return "version: 1\n"
           "dds:\n"
           "  status_period_s: 0.2\n"
           "  cyclonedds_config: '" +
           cyclonedds_config +
           "'\n"
           "frames:\n"
           "  assembly_wait_ms: 50\n"
           "log:\n"
           "  level: info\n"
           "  timing_summary_period_s: 0\n";
  }

  /// The loopback network config plus the security fragment of `identity`.
  [[nodiscard]] std::string profile(const std::string& identity) const {
    return network_ + ",file://" + (pki_ / ("cyclonedds-secure-" + identity + ".xml")).string();
  }

  /// A client of this test process with the given Cyclone config.
  std::unique_ptr<Client> connect(const std::string& scene, const std::string& config) {
    client::Options o;
    o.domain = domain_;
    o.scene = scene;
    o.cyclonedds_config = config;
    return Client::connect(o);
  }

  /// Starts itest_security_peer `mode` with `config` in `scene` for `seconds`.
  void start_peer(const std::string& mode, const std::string& config, const std::string& scene,
                  double seconds) {
    const std::string peer = program_from_env("TC_SECURITY_PEER");
    ASSERT_FALSE(peer.empty());
    ASSERT_TRUE(
        peer_.start({peer, mode, std::to_string(domain_), config, scene, std::to_string(seconds)},
                    dir_ / "peer.out", dir_ / "peer.err"));
  }
  /// Waits for the peer's last line, then its exit; its key=value output.
  std::map<std::string, std::string> finish_peer(const std::string& last_key) {
    EXPECT_TRUE(wait_for_file_text(dir_ / "peer.out", last_key + "=", 30s))
        << slurp(dir_ / "peer.out") << slurp(dir_ / "peer.err");
    peer_.stop(SIGTERM, 10s);
    return parse_peer(dir_ / "peer.out");
  }

  /// A served client streams in scene "shared" while the peer ("intruder") runs beside it;
  /// the peer must never match: no service status, no registration, no forces for it,
  /// and nothing of it in the daemon's log. Returns the peer's output.
  std::map<std::string, std::string> expect_the_peer_kept_out(const std::string& client_profile) {
    auto c = connect("shared", profile(client_profile));
    const auto events = stream_two_boxes(*c, 30);
    for (const auto& e : events) EXPECT_NE(e.object, "intruder") << e.message;
    auto peer = finish_peer("forces");
    EXPECT_EQ(peer["connected"], "1") << peer["connect_error"];
    EXPECT_EQ(peer["status_events"], "0");
    EXPECT_EQ(peer["registered"], "0");
    EXPECT_EQ(peer["forces"], "0");
    EXPECT_EQ(daemon_->log_text().find("intruder"), std::string::npos) << "the peer's data got in";
    return peer;
  }

  /// Streams two overlapping boxes in `scene` for `frames` frames; every frame must be
  /// answered and some must carry forces. Returns the status events seen.
  std::vector<client::StatusEvent> stream_two_boxes(Client& c, int frames,
                                                    const std::string& a_name = "a",
                                                    const std::string& b_name = "b") {
    std::vector<client::StatusEvent> events;
    const client::Mesh a = box_mesh(2, {-0.5, -0.5, -0.5}, {0.5, 0.5, 0.5});
    const client::Mesh b = box_mesh(2, {0.3, -0.4, -0.4}, {1.3, 0.6, 0.6});
    EXPECT_TRUE(c.wait_for_service(20s)) << "the client never saw the service";
    c.register_object(a_name, a, {});
    c.register_object(b_name, b, {});
    EXPECT_TRUE(c.wait_registered(a_name, 10s).ok);
    EXPECT_TRUE(c.wait_registered(b_name, 10s).ok);
    int with_forces = 0;
    for (std::int64_t f = 0; f < frames; ++f) {
      const auto pa = translated(a, {0.0, 0.0, 0.002 * static_cast<double>(f % 10)});
      const auto pb = translated(b, {-0.003 * static_cast<double>(f % 10), 0.0, 0.0});
      c.publish_states(f, {{a_name, pa}, {b_name, pb}});
      const auto forces = c.wait_forces(f, 5s);
      EXPECT_TRUE(forces && forces->frame == f) << "frame " << f << " not answered";
      if (!forces) break;
      EXPECT_TRUE(forces->ok());
      const auto* fa = forces->find(a_name);
      if (fa != nullptr && !fa->nodes.empty()) ++with_forces;
    }
    EXPECT_GT(with_forces, 0) << "overlapping boxes but no contact forces";
    for (auto& e : c.take_status_events()) events.push_back(std::move(e));
    return events;
  }

  std::uint32_t domain_ = private_domain();
  std::filesystem::path dir_;
  std::filesystem::path pki_;
  std::string network_;
  std::unique_ptr<DaemonProcess> daemon_;
  ChildProcess peer_;
};

// (a) A client whose certificate the identity CA signed, with valid permissions,
// registers objects and gets forces from the secured daemon.
TEST_F(SecurityTest, TheRightCertificateGetsForces) {
  auto c = connect("secure", profile("client"));
  stream_two_boxes(*c, 30);
  EXPECT_NE(daemon_->log_text().find("secure/a: topology version 1 received"), std::string::npos);
}

// (b) A client whose certificate a foreign CA signed (same subject name as the genuine
// client, presenting the genuine client's signed permissions) never matches: it sees no
// service status and no forces, and the daemon never receives its topology, while a
// genuine client in the same scene is served at the same time.
TEST_F(SecurityTest, AForeignCaIsRejected) {
  start_peer("client", profile("foreign_client"), "shared", 5.0);
  expect_the_peer_kept_out("client");
  const std::string log = daemon_->log_text();
  // Cyclone reports the failed handshake on stderr ("Begin handshake reply failed:
  // Certificate not valid: ... unable to get local issuer certificate") on the side that
  // validates the other's certificate first: in every run seen the daemon (the daemon
  // log), but the handshake roles are Cyclone's choice, so the peer's stderr counts too.
  const std::string peer_err = slurp(dir_ / "peer.err");
  EXPECT_TRUE(log.find("Certificate not valid") != std::string::npos ||
              peer_err.find("Certificate not valid") != std::string::npos)
      << "no authentication failure reported\n---- peer stderr ----\n"
      << peer_err;
  std::cout << "authentication failure logged by: "
            << (log.find("Certificate not valid") != std::string::npos ? "daemon " : "")
            << (peer_err.find("Certificate not valid") != std::string::npos ? "peer" : "") << "\n";
}

// (c) A participant without security never matches the secured daemon: no data either
// way (it gets no status heartbeats and no forces; its topology never reaches the daemon).
TEST_F(SecurityTest, AnUnsecuredParticipantNeverMatches) {
  start_peer("client", network_, "shared", 5.0);
  expect_the_peer_kept_out("client");
}

// (d) A client whose permissions deny the force topic cannot read (or write) forces: the
// access-control plugin refuses even to create the ContactForces topic on its participant
// (no publish or subscribe right on it), so libtetcollide_client refuses to connect and a
// bare participant gets no ContactForces reader or writer. The same identity
// authenticates and reads ServiceStatus (allowed), and an allowed client gets forces at
// the same time.
TEST_F(SecurityTest, APermissionDenyingTheForceTopicDeniesIt) {
  start_peer("noforces", profile("client_noforces"), "shared", 20.0);
  auto c = connect("shared", profile("client"));
  stream_two_boxes(*c, 30);
  auto peer = finish_peer("status_samples");
  const std::string& error = peer["client_error"];
  EXPECT_NE(error.find("tetcollide/ContactForces"), std::string::npos) << error;
  EXPECT_NE(error.find("Not Allowed By Security"), std::string::npos) << error;
  EXPECT_NE(peer["forces_reader"], "ok");
  EXPECT_NE(peer["forces_writer"], "ok");
  EXPECT_EQ(peer["status_reader"], "ok");
  EXPECT_NE(peer["status_samples"], "0") << "the denied client did not authenticate at all";
}

// Encryption: on the wire (loopback, captured with a packet socket) the object names a
// plain client sends (sample keys, in every MeshTopology and MeshState) appear in clear;
// those the secured client sends never do, although its exchange is captured too (every
// frame answered, packets seen).
TEST_F(SecurityTest, TrafficIsEncryptedOnTheWire) {
  // The control runs a second, plain daemon on domain 231, which private_domain() never
  // gives ([10, 229]); and only in a private network namespace when that can be told.
  std::error_code ec1, ec2;
  const auto own_ns = std::filesystem::read_symlink("/proc/self/ns/net", ec1);
  const auto init_ns = std::filesystem::read_symlink("/proc/1/ns/net", ec2);
  if (!ec1 && !ec2 && own_ns == init_ns)
    GTEST_SKIP() << "not in a private network namespace (run it through run_isolated.sh)";
  LoopbackCapture capture;
  if (!capture.ok()) GTEST_SKIP() << "no packet socket (needs CAP_NET_RAW): " << strerror(errno);
  // Control: a plain daemon and client on another domain, same capture.
  const std::uint32_t plain_domain = 231;
  const auto plain_dir = dir_ / "plain";
  std::filesystem::create_directories(plain_dir);
  {
    DaemonProcess plain(plain_dir, plain_domain, daemon_config(network_));
    ASSERT_TRUE(plain.start()) << plain.log_text();
    client::Options o;
    o.domain = plain_domain;
    o.scene = "clear";
    o.cyclonedds_config = network_;
    auto c = Client::connect(o);
    stream_two_boxes(*c, 10, "marker-in-clear-a", "marker-in-clear-b");
  }
  EXPECT_TRUE(capture.contains("marker-in-clear-a")) << "the capture does not see DDS data";
  capture.clear();
  const std::size_t before = capture.packets();
  auto c = connect("secret", profile("client"));
  stream_two_boxes(*c, 10, "marker-secret-a", "marker-secret-b");
  EXPECT_GT(capture.packets(), before + 40) << "the secured exchange was not captured";
  EXPECT_FALSE(capture.contains("marker-secret-a")) << "an object name went out in clear";
  EXPECT_FALSE(capture.contains("marker-secret-b")) << "an object name went out in clear";
}

}  // namespace
}  // namespace tc::itest
