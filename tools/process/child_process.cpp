#include "child_process.hpp"

#include <fcntl.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <thread>
#include <utility>

namespace tc::process {
namespace {

using Clock = std::chrono::steady_clock;

/// How often a bounded wait looks whether the child has exited.
constexpr std::chrono::milliseconds kPollPeriod{5};

/// Makes `fd` the child's descriptor `target`, open across exec (the parent opened it
/// close-on-exec, so other children started meanwhile do not inherit it).
void redirect(int fd, int target) {
  if (fd < 0) return;
  if (fd == target) {
    fcntl(fd, F_SETFD, 0);
  } else {
    dup2(fd, target);
  }
}

}  // namespace

int exit_code(int status) {
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

Child::~Child() {
  kill_and_reap();
}

Child::Child(Child&& other) noexcept
    : pid_(std::exchange(other.pid_, -1)), status_(other.status_) {}

Child& Child::operator=(Child&& other) noexcept {
  if (this != &other) {
    kill_and_reap();
    pid_ = std::exchange(other.pid_, -1);
    status_ = other.status_;
  }
  return *this;
}

Status Child::start(const SpawnOptions& options) {
  kill_and_reap();
  if (options.argv.empty()) return Error{ErrorCode::kInvalidArgument, "no program to start"};
  // Everything the child needs is prepared here: between fork and exec it only makes
  // system calls.
  const std::string program = options.program.empty() ? options.argv[0] : options.program.string();
  std::vector<char*> args;
  for (const auto& a : options.argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const int flags = O_WRONLY | O_CREAT | O_CLOEXEC | (options.truncate ? O_TRUNC : O_APPEND);
  int out = -1;
  int err = -1;
  const auto close_files = [&] {
    if (out >= 0) close(out);
    if (err >= 0 && err != out) close(err);
  };
  if (!options.out.empty()) {
    out = open(options.out.c_str(), flags, 0644);
    if (out < 0) return Error{ErrorCode::kIo, "cannot open " + options.out.string()};
  }
  if (!options.err.empty()) {
    err = options.err == options.out ? out : open(options.err.c_str(), flags, 0644);
    if (err < 0) {
      close_files();
      return Error{ErrorCode::kIo, "cannot open " + options.err.string()};
    }
  }
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid < 0) {
    close_files();
    return Error{ErrorCode::kIo, "fork failed"};
  }
  if (pid == 0) {
    prctl(PR_SET_PDEATHSIG, options.parent_death_signal);
    if (getppid() != parent) _exit(127);  // the parent died before prctl
    if (options.reset_signals) {
      ::signal(SIGINT, SIG_DFL);
      ::signal(SIGTERM, SIG_DFL);
      sigset_t none;
      sigemptyset(&none);
      sigprocmask(SIG_SETMASK, &none, nullptr);
    }
    if (options.own_process_group) setpgid(0, 0);
    redirect(out, STDOUT_FILENO);
    redirect(err, STDERR_FILENO);
    execv(program.c_str(), args.data());
    _exit(127);
  }
  close_files();
  pid_ = pid;
  status_ = 0;
  return {};
}

bool Child::exited() {
  if (pid_ <= 0) return true;
  int status = 0;
  const pid_t r = waitpid(pid_, &status, WNOHANG);
  if (r == 0) return false;
  if (r == pid_) status_ = status;
  pid_ = -1;  // exited, or not ours to wait for any more
  return true;
}

std::optional<int> Child::wait_for(std::chrono::milliseconds timeout) {
  if (pid_ <= 0) return std::nullopt;
  const auto deadline = Clock::now() + timeout;
  for (;;) {
    int status = 0;
    const pid_t r = waitpid(pid_, &status, WNOHANG);
    if (r == pid_) {
      pid_ = -1;
      status_ = status;
      return status;
    }
    if (r < 0) {
      pid_ = -1;
      return std::nullopt;
    }
    if (Clock::now() >= deadline) return std::nullopt;
    std::this_thread::sleep_for(kPollPeriod);
  }
}

int Child::wait() {
  if (pid_ <= 0) return -1;
  int status = 0;
  const pid_t r = waitpid(pid_, &status, 0);
  pid_ = -1;
  if (r < 0) return -1;
  status_ = status;
  return status;
}

void Child::signal(int sig) const {
  if (pid_ > 0) ::kill(pid_, sig);
}

std::optional<int> Child::stop(int sig, std::chrono::milliseconds timeout) {
  if (pid_ <= 0) return std::nullopt;
  signal(sig);
  const std::optional<int> status = wait_for(timeout);
  if (!status) kill_and_reap();
  return status;
}

void Child::kill_and_reap() {
  if (pid_ <= 0) return;
  ::kill(pid_, SIGKILL);
  int status = 0;
  if (waitpid(pid_, &status, 0) == pid_) status_ = status;
  pid_ = -1;
}

}  // namespace tc::process
