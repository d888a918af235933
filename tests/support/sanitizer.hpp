// Whether this build runs under a sanitizer. Timing and memory bounds that the tests
// check in Release are loosened there: ASan and TSan slow the code 2-15x, and ASan keeps
// freed memory in its quarantine, so RSS is no measure of a leak (LeakSanitizer is).
#pragma once

namespace tc::test {

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
inline constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif
#else
inline constexpr bool kSanitized = false;
#endif

/// Factor on a time bound measured in Release.
inline constexpr double kTimeSlack = kSanitized ? 4.0 : 1.0;

}  // namespace tc::test
