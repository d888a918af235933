// Fuzz target: the recording file parser of `tetcollide replay` (tools/replay,
// docs/RECORDING.md). The input is the file's content. Every input must give the
// records or an error naming the line; every record read must encode and decode back.
#include <cstdint>

#include "fuzz_input.hpp"
#include "recording.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto records = tc::replay::read_recording_buffer(tc::fuzz::as_text(data, size), "fuzz");
  if (!records) {
    TC_FUZZ_CHECK(!records.error().message.empty());
    return 0;
  }
  for (const tc::replay::Record& record : *records) {
    const std::string line = tc::replay::encode_record(record);
    const auto back = tc::replay::decode_record(line, "fuzz:re-encoded");
    TC_FUZZ_CHECK(static_cast<bool>(back));
    TC_FUZZ_CHECK(back->index() == record.index());
  }
  return 0;
}
