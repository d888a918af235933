// Several hosts (issue 15): the daemon and the simulator in two network namespaces joined
// by a veth pair (VirtualLan), both on config/cyclonedds-network.xml (multicast discovery
// on the veth, 169.254.77.x link-local addresses). The committed recordings replay bit for
// bit across the two "hosts", plain and with the DDS Security profile. Needs root; skips
// with the reason elsewhere. Label: integration, hosts.
#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>
#include <nlohmann/json.hpp>

#include "daemon_process.hpp"
#include "scenarios.hpp"
#include "virtual_lan.hpp"

namespace tc::itest {
namespace {

using namespace std::chrono_literals;

/// file:// URI of config/cyclonedds-network.xml (TC_NETWORK_CONFIG, set by CTest).
std::string network_config() {
  return "file://" + program_from_env("TC_NETWORK_CONFIG");
}

/// Bytes received on host's tc0 ("ip -s link"), -1 when unreadable.
long long received_bytes(const VirtualLan& lan, int host) {
  auto argv = lan.exec_prefix(host);
  argv.insert(argv.end(), {"/bin/cat", "/sys/class/net/tc0/statistics/rx_bytes"});
  const RunResult r = run_program(argv, 20s);
  if (r.exit_code != 0) return -1;
  return std::stoll(r.out);
}

class HostsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (const std::string why = VirtualLan::unavailable_reason(); !why.empty())
      GTEST_SKIP() << "several-host test skipped: " << why;
    lan_ = std::make_unique<VirtualLan>(2);
    ASSERT_TRUE(lan_->ok()) << lan_->error();
    dir_ = make_temp_dir("itest-hosts");
  }
  void TearDown() override {
    if (HasFailure() && daemon_) std::cerr << "---- daemon log ----\n" << daemon_->log_text();
    daemon_.reset();
    lan_.reset();
    if (!dir_.empty()) std::filesystem::remove_all(dir_);
  }

  /// Starts the daemon on host 0 with the given Cyclone config.
  void start_daemon(const std::string& cyclonedds_config) {
    daemon_ = std::make_unique<DaemonProcess>(dir_, domain_,
                                              "version: 1\n"
                                              "dds:\n"
                                              "  status_period_s: 0.2\n"
                                              "  cyclonedds_config: '" +
                                                  cyclonedds_config +
                                                  "'\n"
                                                  "log:\n"
                                                  "  timing_summary_period_s: 0\n");
    daemon_->set_command_prefix(lan_->exec_prefix(0));
    ASSERT_TRUE(daemon_->start()) << daemon_->log_text();
  }

  /// `tetcollide replay --check` of every committed recording on host 1.
  void replay_committed_recordings(const std::string& cyclonedds_config) {
    const auto files = committed_recordings();
    ASSERT_EQ(files.size(), scenario_names().size()) << "recordings in " << recordings_dir();
    const long long before = received_bytes(*lan_, 0);
    for (const auto& file : files) {
      SCOPED_TRACE(file.string());
      auto argv = lan_->exec_prefix(1, {"CYCLONEDDS_URI=" + cyclonedds_config});
      argv.insert(argv.end(), {program_from_env("TC_CLI"), "replay", file.string(), "--domain",
                               std::to_string(domain_), "--rate", "0", "--check", "--json"});
      const RunResult r = run_program(argv, 90s);
      ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
      const auto j = nlohmann::json::parse(r.out);
      EXPECT_GT(j["frames"].get<int>(), 0);
      EXPECT_EQ(j["mismatched_frames"].get<int>(), 0);
      EXPECT_EQ(j["max_force_deviation"].get<double>(), 0.0);
    }
    // The frames went over the veth: the daemon's host received them there.
    EXPECT_GT(received_bytes(*lan_, 0), before + 100000);
  }

  std::uint32_t domain_ = private_domain();
  std::unique_ptr<VirtualLan> lan_;
  std::filesystem::path dir_;
  std::unique_ptr<DaemonProcess> daemon_;
};

TEST_F(HostsTest, CommittedRecordingsReplayAcrossTwoHosts) {
  start_daemon(network_config());
  replay_committed_recordings(network_config());
}

TEST_F(HostsTest, CommittedRecordingsReplayAcrossTwoHostsWithSecurity) {
  const auto pki = dir_ / "pki";
  const RunResult made =
      run_program({"/bin/sh", program_from_env("TC_SECURITY_PKI_SCRIPT"), pki.string()}, 60s);
  ASSERT_EQ(made.exit_code, 0) << made.out << made.err;
  const auto profile = [&](const std::string& identity) {
    return network_config() + ",file://" +
           (pki / ("cyclonedds-secure-" + identity + ".xml")).string();
  };
  start_daemon(profile("service"));
  // The secured daemon matches only secured participants of the test CA
  // (SecurityTest.AnUnsecuredParticipantNeverMatches): the replay is secured end to end.
  replay_committed_recordings(profile("client"));
}

}  // namespace
}  // namespace tc::itest
