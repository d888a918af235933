// Helpers of the package tests (tests/package): shell commands, the daemon of an
// installed tree.
#pragma once

#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

#include "daemon_process.hpp"

namespace tc::itest {

/// `command` run by /bin/sh -c, stdout and stderr captured, killed after `timeout`.
RunResult sh(const std::string& command,
             std::chrono::milliseconds timeout = std::chrono::seconds(120));

/// `text` quoted for /bin/sh.
std::string quoted(const std::string& text);

/// Starts `argv` (a tetcollided, possibly behind a wrapper) with stderr to `log`, and
/// waits for its "tetcollided ready" line. False on timeout (the child is then killed).
bool start_daemon(ChildProcess& daemon, const std::vector<std::string>& argv,
                  const std::filesystem::path& dir, std::chrono::milliseconds timeout);

/// Text of a file, or "" when it cannot be read.
std::string file_text(const std::filesystem::path& path);

}  // namespace tc::itest
