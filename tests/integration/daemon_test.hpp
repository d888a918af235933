// The fixture of the tests that run one daemon: a private domain, a fresh directory, the
// daemon started from the derived fixture's SetUp() and its log printed when a test fails.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

#include "daemon_process.hpp"
#include "tetcollide/client.hpp"

namespace tc::itest {

class DaemonTest : public ::testing::Test {
 protected:
  /// Starts the daemon with `config_yaml` in a fresh directory named after `dir_prefix`;
  /// a fatal failure (with the daemon's log) when it does not get ready.
  void start_daemon(const std::string& dir_prefix, const std::string& config_yaml) {
    dir_ = make_temp_dir(dir_prefix);
    restart_daemon(config_yaml);
  }

  /// Stops the daemon (if any) and starts a new one with `config_yaml` in the same
  /// directory and domain.
  void restart_daemon(const std::string& config_yaml) {
    daemon_.reset();
    daemon_ = std::make_unique<DaemonProcess>(dir_, domain_, config_yaml);
    ASSERT_TRUE(daemon_->start()) << daemon_->log_text();
  }

  void TearDown() override {
    if (HasFailure() && daemon_) std::cerr << "---- daemon log ----\n" << daemon_->log_text();
    daemon_.reset();
    std::filesystem::remove_all(dir_);
  }

  /// A client of scene `scene` on this test's domain, once the service is ready and its
  /// reader of the states is matched (a state written before that reaches nobody); a test
  /// failure, not a fatal one, when they are not within `ready`.
  std::unique_ptr<client::Client> connect(
      const std::string& scene, std::chrono::milliseconds resend = std::chrono::milliseconds(0),
      std::chrono::milliseconds ready = std::chrono::seconds(10)) {
    client::Options o;
    o.domain = domain_;
    o.scene = scene;
    o.resend_after = resend;
    auto c = client::Client::connect(o);
    EXPECT_TRUE(c->wait_for_service(ready)) << "no READY service on domain " << domain_;
    EXPECT_TRUE(c->wait_for_readers(1, ready)) << "no reader of the states on domain " << domain_;
    return c;
  }

  std::uint32_t domain_ = private_domain();
  std::filesystem::path dir_;
  std::unique_ptr<DaemonProcess> daemon_;
};

}  // namespace tc::itest
