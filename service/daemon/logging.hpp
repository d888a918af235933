// spdlog set-up for the daemon: stderr (and optionally a file), the level from the
// configuration, and the core's log facade (tc::set_log_sink) wired to the same logger.
#pragma once

#include <string>

#include "core/common/result.hpp"

namespace tc::daemon {

/// Installs the default spdlog logger "tetcollided" at `level` (trace | debug | info |
/// warn | error | off), appending to `file` as well when it is not empty, and routes
/// tc::log() into it. kInvalidArgument for an unknown level, kIo when the file cannot be
/// opened.
Status setup_logging(const std::string& level, const std::string& file);

}  // namespace tc::daemon
