#pragma once
// Words of Prophesee's EVT 2.0 format that more than one test writes by hand.
#include <cstdint>

namespace fdv::test {

/// EVT 2.0 EVT_TIME_HIGH (type 0x8): the upper 28 bits of a timestamp in µs.
constexpr std::uint32_t th2(std::uint32_t high) { return 0x8u << 28 | high; }

}  // namespace fdv::test
