#include "package_support.hpp"

#include <csignal>
#include <fstream>
#include <sstream>

namespace tc::itest {

RunResult sh(const std::string& command, std::chrono::milliseconds timeout) {
  return run_program({"/bin/sh", "-c", command}, timeout);
}

std::string quoted(const std::string& text) {
  std::string out = "'";
  for (const char c : text) {
    if (c == '\'')
      out += "'\\''";
    else
      out += c;
  }
  return out + "'";
}

std::string file_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream out;
  out << in.rdbuf();
  return out.str();
}

bool start_daemon(ChildProcess& daemon, const std::vector<std::string>& argv,
                  const std::filesystem::path& dir, std::chrono::milliseconds timeout) {
  if (!daemon.start(argv, dir / "daemon.out", dir / "daemon.log")) return false;
  if (wait_for_file_text(dir / "daemon.log", "tetcollided ready", timeout)) return true;
  daemon.stop(SIGKILL);
  return false;
}

}  // namespace tc::itest
