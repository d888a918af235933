// Fuzz target: the daemon's configuration parser (YAML text). Every document must give
// a configuration or an error with a message; a configuration parse_config accepts must
// also pass check_config (the rules applied after command-line overrides).
#include <cstdint>

#include "config.hpp"
#include "fuzz_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto parsed = tc::daemon::parse_config(tc::fuzz::as_text(data, size), "fuzz.yaml");
  if (parsed) {
    TC_FUZZ_CHECK(tc::daemon::check_config(*parsed).ok());
  } else {
    TC_FUZZ_CHECK(!parsed.error().message.empty());
  }
  return 0;
}
