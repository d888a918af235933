// Taking every available sample of a reader in loaned batches: the dds_take /
// dds_return_loan loop the daemon, the client library and the recorder share. Header-only
// (a template): the shared client library exports no symbol of it.
#pragma once

#include <dds/dds.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

namespace tc::protocol {

/// Samples taken from a reader at a time.
inline constexpr std::uint32_t kTakeBatch = 64;

/// Takes every sample `reader` holds, kTakeBatch at a time, until a batch comes back short.
/// Each batch is loaned: `batch(samples, infos)` sees it while the loan is held (samples
/// are the untyped loaned pointers; a sample whose info has no valid_data still points at
/// its key fields) and returns false to stop after it. The loan is then returned and
/// `loan_returned(rc)` is given dds_return_loan's result; it returns false to stop (or
/// throws). Returns dds_take's result if it failed (negative), 0 otherwise; the caller
/// reports the failure its own way.
template <typename Batch, typename LoanReturned>
dds_return_t take_all(dds_entity_t reader, Batch&& batch, LoanReturned&& loan_returned) {
  std::array<void*, kTakeBatch> samples{};
  std::array<dds_sample_info_t, kTakeBatch> infos{};
  for (;;) {
    samples.fill(nullptr);
    const dds_return_t n = dds_take(reader, samples.data(), infos.data(), kTakeBatch, kTakeBatch);
    if (n < 0) return n;
    const auto count = static_cast<std::size_t>(n);
    const bool more = batch(std::span<void* const>(samples.data(), count),
                            std::span<const dds_sample_info_t>(infos.data(), count));
    if (!loan_returned(dds_return_loan(reader, samples.data(), n)) || !more) return 0;
    if (n < static_cast<dds_return_t>(kTakeBatch)) return 0;
  }
}

}  // namespace tc::protocol
