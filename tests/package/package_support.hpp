// Helpers of the package tests (tests/package): shell commands, the Debian packages as
// dpkg-deb sees them, the daemon of an installed tree, the consumer program built
// against an installed client library.
#pragma once

#include <chrono>
#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "daemon_process.hpp"

namespace tc::itest {

/// `command` run by /bin/sh -c, stdout and stderr captured, killed after `timeout`.
RunResult sh(const std::string& command,
             std::chrono::milliseconds timeout = std::chrono::seconds(120));

/// `text` quoted for /bin/sh.
std::string quoted(const std::string& text);

/// A .deb as dpkg-deb reports it.
struct Deb {
  std::filesystem::path file;
  std::map<std::string, std::string> fields;  ///< control fields (Package, Depends, ...)
  std::set<std::string> paths;  ///< every path in data.tar, absolute, dirs without "/"
  std::set<std::string> dirs;   ///< the directories among them
  std::map<std::string, std::string> control;  ///< control.tar members: conffiles, postinst...
  std::set<std::string> executable_control;    ///< control members with an x bit
};

/// Reads a .deb with dpkg-deb -f, -c and -e; fails the test on an error.
Deb read_deb(const std::filesystem::path& file);

/// The package names of a Depends-like field, without versions ("libc6 (>= 2.34), a | b"
/// gives libc6, a, b).
std::set<std::string> depends_names(const std::string& field);

/// Starts `argv` (a tetcollided, possibly behind a wrapper) with stderr to `log`, and
/// waits for its "tetcollided ready" line. False on timeout (the child is then killed).
bool start_daemon(ChildProcess& daemon, const std::vector<std::string>& argv,
                  const std::filesystem::path& dir, std::chrono::milliseconds timeout);

/// Text of a file, or "" when it cannot be read.
std::string file_text(const std::filesystem::path& path);

}  // namespace tc::itest
