// One logger, replaceable: the core logs through this facade; the daemon and the CLI
// wire it to spdlog. Never called from hot loops.
#pragma once

#include <functional>
#include <string_view>

namespace tc {

enum class LogLevel { kTrace, kDebug, kInfo, kWarn, kError };

using LogSink = std::function<void(LogLevel, std::string_view)>;

/// Installs the sink that receives every core log message (default: stderr for
/// warnings and errors, nothing else). Not thread-safe against concurrent logging:
/// call once at start-up.
void set_log_sink(LogSink sink);

/// Sends a message to the installed sink.
void log(LogLevel level, std::string_view message);

}  // namespace tc
