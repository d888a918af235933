#include "logging.hpp"

#include <spdlog/sinks/basic_file_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <memory>
#include <vector>

#include "core/common/log.hpp"

namespace tc::daemon {

Status setup_logging(const std::string& level, const std::string& file) {
  const auto lvl = spdlog::level::from_str(level);
  if (lvl == spdlog::level::off && level != "off")
    return Error{ErrorCode::kInvalidArgument,
                 "unknown log level '" + level + "' (trace, debug, info, warn, error, off)"};
  std::vector<spdlog::sink_ptr> sinks;
  sinks.push_back(std::make_shared<spdlog::sinks::stderr_color_sink_mt>());
  if (!file.empty()) {
    try {
      sinks.push_back(std::make_shared<spdlog::sinks::basic_file_sink_mt>(file, false));
    } catch (const spdlog::spdlog_ex& e) {
      return Error{ErrorCode::kIo, file + ": cannot open the log file: " + e.what()};
    }
  }
  auto logger = std::make_shared<spdlog::logger>("tetcollided", sinks.begin(), sinks.end());
  logger->set_level(lvl);
  logger->set_pattern("%Y-%m-%dT%H:%M:%S.%e [%^%l%$] %v");
  logger->flush_on(spdlog::level::info);
  spdlog::set_default_logger(logger);
  tc::set_log_sink([](LogLevel l, std::string_view message) {
    switch (l) {
      case LogLevel::kTrace:
        spdlog::trace("core: {}", message);
        break;
      case LogLevel::kDebug:
        spdlog::debug("core: {}", message);
        break;
      case LogLevel::kInfo:
        spdlog::info("core: {}", message);
        break;
      case LogLevel::kWarn:
        spdlog::warn("core: {}", message);
        break;
      case LogLevel::kError:
        spdlog::error("core: {}", message);
        break;
    }
  });
  return {};
}

}  // namespace tc::daemon
