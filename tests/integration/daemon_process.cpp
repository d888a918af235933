#include "daemon_process.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <random>
#include <sstream>
#include <thread>

namespace tc::itest {
namespace {

using Clock = std::chrono::steady_clock;

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream out;
  out << in.rdbuf();
  return out.str();
}

}  // namespace

std::uint32_t private_domain() {
  return 10 + static_cast<std::uint32_t>(getpid()) % 220;
}

std::filesystem::path make_temp_dir(const std::string& prefix) {
  std::filesystem::path base = std::filesystem::temp_directory_path();
  if (const char* t = std::getenv("TC_TEST_TMP")) base = t;
  std::filesystem::create_directories(base);
  std::mt19937_64 rng(static_cast<std::uint64_t>(getpid()) * 1000003u +
                      static_cast<std::uint64_t>(Clock::now().time_since_epoch().count()));
  for (int attempt = 0; attempt < 100; ++attempt) {
    auto dir =
        base / (prefix + "-" + std::to_string(getpid()) + "-" + std::to_string(rng() % 1000000));
    if (std::filesystem::create_directory(dir)) return dir;
  }
  ADD_FAILURE() << "cannot create a temporary directory under " << base;
  return base;
}

std::string program_from_env(const char* variable) {
  const char* v = std::getenv(variable);
  if (v == nullptr || *v == '\0') {
    ADD_FAILURE() << variable << " is not set (run the test through ctest)";
    return {};
  }
  return v;
}

std::filesystem::path recordings_dir() {
  return program_from_env("TC_RECORDINGS");
}

std::vector<std::filesystem::path> committed_recordings() {
  std::vector<std::filesystem::path> files;
  const auto dir = recordings_dir();
  if (dir.empty()) return files;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    if (e.path().extension() == ".jsonl") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return files;
}

DaemonProcess::DaemonProcess(std::filesystem::path dir, std::uint32_t domain,
                             std::string config_yaml)
    : dir_(std::move(dir)),
      config_(dir_ / "tetcollided.yaml"),
      log_(dir_ / "daemon.log"),
      domain_(domain) {
  std::ofstream(config_) << config_yaml;
}

DaemonProcess::~DaemonProcess() = default;

bool DaemonProcess::start(std::chrono::milliseconds timeout) {
  const std::string daemon = program_from_env("TC_DAEMON");
  if (daemon.empty()) return false;
  ++starts_;
  // Each start appends to the same log; readiness is the n-th "ready" line.
  std::vector<std::string> argv = prefix_;
  argv.insert(argv.end(),
              {daemon, "--config", config_.string(), "--domain", std::to_string(domain_)});
  if (!child_.start({.argv = argv, .out = dir_ / "daemon.out", .err = log_})) return false;
  const auto deadline = Clock::now() + timeout;
  while (Clock::now() < deadline) {
    const std::string text = log_text();
    std::size_t count = 0;
    for (std::size_t p = text.find("tetcollided ready"); p != std::string::npos;
         p = text.find("tetcollided ready", p + 1))
      ++count;
    if (count >= static_cast<std::size_t>(starts_)) return true;
    if (child_.exited()) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

int DaemonProcess::stop(int sig, std::chrono::milliseconds timeout) {
  return child_.stop(sig, timeout).value_or(-1);
}

void DaemonProcess::kill_hard() {
  child_.stop(SIGKILL, std::chrono::seconds(10));
}

std::string DaemonProcess::log_text() const {
  return read_file(log_);
}

bool DaemonProcess::wait_for_log(const std::string& text, std::chrono::milliseconds timeout) const {
  const auto deadline = Clock::now() + timeout;
  while (Clock::now() < deadline) {
    if (log_text().find(text) != std::string::npos) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

bool ChildProcess::start(const std::vector<std::string>& argv, const std::filesystem::path& out,
                         const std::filesystem::path& err) {
  return child_.start({.argv = argv, .out = out, .err = err}).ok();
}

int ChildProcess::stop(int sig, std::chrono::milliseconds timeout) {
  const std::optional<int> status = child_.stop(sig, timeout);
  return status ? process::exit_code(*status) : -1;
}

bool wait_for_file_text(const std::filesystem::path& path, const std::string& text,
                        std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  while (Clock::now() < deadline) {
    if (read_file(path).find(text) != std::string::npos) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

RunResult run_program(const std::vector<std::string>& argv, std::chrono::milliseconds timeout) {
  const auto dir = make_temp_dir("run");
  RunResult r;
  process::Child child;
  if (child.start({.argv = argv, .out = dir / "out", .err = dir / "err"})) {
    if (const std::optional<int> status = child.wait_for(timeout)) {
      r.exit_code = process::exit_code(*status);
    } else {
      child.stop(SIGKILL, std::chrono::seconds(10));
    }
  }
  r.out = read_file(dir / "out");
  r.err = read_file(dir / "err");
  std::filesystem::remove_all(dir);
  return r;
}

}  // namespace tc::itest
