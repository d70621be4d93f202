// Time on the car is a free-running 32-bit microsecond counter (Arduino micros(), a timer on
// other boards, the simulated clock on the host). It wraps every 71.6 minutes, so durations
// are always computed as unsigned differences, never by comparing two timestamps.
#pragma once
#include <stdint.h>

namespace roar {

using Micros = uint32_t;  // [us] free-running, wraps

// [us] time from `since` to `now`, correct across one wrap of the counter.
inline Micros elapsed_us(Micros now, Micros since) { return static_cast<Micros>(now - since); }

}  // namespace roar
