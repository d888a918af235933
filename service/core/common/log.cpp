#include "core/common/log.hpp"

#include <cstdio>
#include <utility>

namespace tc {
namespace {

void default_sink(LogLevel level, std::string_view message) {
  if (level < LogLevel::kWarn) return;
  std::fprintf(stderr, "[tetcollide %s] %.*s\n", level == LogLevel::kWarn ? "warn" : "error",
               static_cast<int>(message.size()), message.data());
}

LogSink& sink_storage() {
  static LogSink sink = default_sink;
  return sink;
}

}  // namespace

void set_log_sink(LogSink sink) {
  sink_storage() = sink ? std::move(sink) : default_sink;
}

void log(LogLevel level, std::string_view message) {
  sink_storage()(level, message);
}

}  // namespace tc
