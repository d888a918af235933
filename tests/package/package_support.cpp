#include "package_support.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>

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

Deb read_deb(const std::filesystem::path& file) {
  Deb deb;
  deb.file = file;
  auto r = sh("dpkg-deb -f " + quoted(file.string()));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  std::istringstream fields(r.out);
  std::string line, key;
  while (std::getline(fields, line)) {
    if (!line.empty() && line[0] == ' ' && !key.empty()) {
      deb.fields[key] += "\n" + line;
      continue;
    }
    const auto colon = line.find(": ");
    if (colon == std::string::npos) continue;
    key = line.substr(0, colon);
    deb.fields[key] = line.substr(colon + 2);
  }
  // "drwxr-xr-x root/root 0 2024-01-01 00:00 ./usr/bin/" and "... ./a.so.0 -> a.so.0.1.0"
  r = sh("dpkg-deb -c " + quoted(file.string()));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  std::istringstream listing(r.out);
  while (std::getline(listing, line)) {
    const auto at = line.find(" ./");
    if (at == std::string::npos) continue;
    std::string path = line.substr(at + 2);
    if (const auto arrow = path.find(" -> "); arrow != std::string::npos) path.resize(arrow);
    const bool dir = line[0] == 'd';
    while (path.size() > 1 && path.back() == '/') path.pop_back();
    if (path == "/") continue;
    deb.paths.insert(path);
    if (dir) deb.dirs.insert(path);
  }
  const auto control = make_temp_dir("deb-control");
  r = sh("dpkg-deb -e " + quoted(file.string()) + " " + quoted((control / "DEBIAN").string()));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  for (const auto& e : std::filesystem::directory_iterator(control / "DEBIAN")) {
    const std::string name = e.path().filename().string();
    deb.control[name] = file_text(e.path());
    struct stat st {};
    if (stat(e.path().c_str(), &st) == 0 && (st.st_mode & S_IXUSR) != 0)
      deb.executable_control.insert(name);
  }
  std::filesystem::remove_all(control);
  return deb;
}

std::set<std::string> depends_names(const std::string& field) {
  std::set<std::string> names;
  std::string token;
  bool in_version = false;
  const auto flush = [&] {
    if (!token.empty()) names.insert(token);
    token.clear();
  };
  for (const char c : field) {
    if (c == '(') {
      in_version = true;
      flush();
    } else if (c == ')') {
      in_version = false;
    } else if (in_version) {
      continue;
    } else if (c == ',' || c == '|' || c == ' ' || c == '\n') {
      flush();
    } else {
      token += c;
    }
  }
  flush();
  return names;
}

bool start_daemon(ChildProcess& daemon, const std::vector<std::string>& argv,
                  const std::filesystem::path& dir, std::chrono::milliseconds timeout) {
  if (!daemon.start(argv, dir / "daemon.out", dir / "daemon.log")) return false;
  if (wait_for_file_text(dir / "daemon.log", "tetcollided ready", timeout)) return true;
  daemon.stop(SIGKILL);
  return false;
}

}  // namespace tc::itest
