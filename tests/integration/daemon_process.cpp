#include "daemon_process.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

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

/// fork + exec with the child killed when the parent dies; stdout/stderr to files.
pid_t spawn(const std::vector<std::string>& argv, const std::filesystem::path& out,
            const std::filesystem::path& err) {
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid != 0) return pid;
  prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (getppid() != parent) _exit(127);
  const int o = open(out.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  const int e = open(err.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  if (o < 0 || e < 0) _exit(126);
  dup2(o, STDOUT_FILENO);
  dup2(e, STDERR_FILENO);
  execv(args[0], args.data());
  _exit(127);
}

/// waitpid with a timeout; returns the status or -1.
int wait_exit(pid_t pid, std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  for (;;) {
    int status = 0;
    const pid_t r = waitpid(pid, &status, WNOHANG);
    if (r == pid) return status;
    if (r < 0) return -1;
    if (Clock::now() >= deadline) return -1;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
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

DaemonProcess::DaemonProcess(std::filesystem::path dir, std::uint32_t domain,
                             std::string config_yaml)
    : dir_(std::move(dir)),
      config_(dir_ / "tetcollided.yaml"),
      log_(dir_ / "daemon.log"),
      domain_(domain) {
  std::ofstream(config_) << config_yaml;
}

DaemonProcess::~DaemonProcess() {
  if (pid_ > 0) kill_hard();
}

bool DaemonProcess::start(std::chrono::milliseconds timeout) {
  const std::string daemon = program_from_env("TC_DAEMON");
  if (daemon.empty()) return false;
  ++starts_;
  // Each start appends to the same log; readiness is the n-th "ready" line.
  std::vector<std::string> argv = prefix_;
  argv.insert(argv.end(),
              {daemon, "--config", config_.string(), "--domain", std::to_string(domain_)});
  pid_ = spawn(argv, dir_ / "daemon.out", log_);
  if (pid_ < 0) return false;
  const auto deadline = Clock::now() + timeout;
  while (Clock::now() < deadline) {
    const std::string text = log_text();
    std::size_t count = 0;
    for (std::size_t p = text.find("tetcollided ready"); p != std::string::npos;
         p = text.find("tetcollided ready", p + 1))
      ++count;
    if (count >= static_cast<std::size_t>(starts_)) return true;
    int status = 0;
    if (waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      return false;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

int DaemonProcess::stop(int sig, std::chrono::milliseconds timeout) {
  if (pid_ <= 0) return -1;
  ::kill(pid_, sig);
  const int status = wait_exit(pid_, timeout);
  if (status < 0) {
    kill_hard();
    return -1;
  }
  pid_ = -1;
  return status;
}

void DaemonProcess::kill_hard() {
  if (pid_ <= 0) return;
  ::kill(pid_, SIGKILL);
  wait_exit(pid_, std::chrono::seconds(10));
  pid_ = -1;
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

ChildProcess::~ChildProcess() {
  if (pid_ > 0) stop(SIGKILL, std::chrono::seconds(10));
}

bool ChildProcess::start(const std::vector<std::string>& argv, const std::filesystem::path& out,
                         const std::filesystem::path& err) {
  pid_ = spawn(argv, out, err);
  return pid_ > 0;
}

int ChildProcess::stop(int sig, std::chrono::milliseconds timeout) {
  if (pid_ <= 0) return -1;
  ::kill(pid_, sig);
  int status = wait_exit(pid_, timeout);
  if (status < 0) {
    ::kill(pid_, SIGKILL);
    wait_exit(pid_, std::chrono::seconds(10));
  }
  pid_ = -1;
  return status >= 0 && WIFEXITED(status) ? WEXITSTATUS(status) : -1;
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
  const pid_t pid = spawn(argv, dir / "out", dir / "err");
  RunResult r;
  const int status = wait_exit(pid, timeout);
  if (status < 0) {
    ::kill(pid, SIGKILL);
    wait_exit(pid, std::chrono::seconds(10));
  } else if (WIFEXITED(status)) {
    r.exit_code = WEXITSTATUS(status);
  }
  r.out = read_file(dir / "out");
  r.err = read_file(dir / "err");
  std::filesystem::remove_all(dir);
  return r;
}

}  // namespace tc::itest
