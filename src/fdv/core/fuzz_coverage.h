#pragma once
/// FDV_NO_FUZZ_COVERAGE before a function that is a loop over pixels or events: the fuzz build
/// (clang, -fsanitize=fuzzer-no-link) then leaves its body without coverage callbacks. They fire at
/// every comparison of every iteration, and in these loops they made most of a fuzz input's time
/// (docs/FORMATS.md, "Fuzzing") while the branches they report are data, not control flow worth
/// exploring. AddressSanitizer and UBSan still check the body. No effect in any other build.
#if defined(__clang__)
#define FDV_NO_FUZZ_COVERAGE __attribute__((no_sanitize("coverage")))
#else
#define FDV_NO_FUZZ_COVERAGE
#endif
