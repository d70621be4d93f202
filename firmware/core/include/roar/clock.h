// Time in the core is Micros: microseconds since boot on a 64-bit counter, which never wraps
// (it would take 584,000 years). Every timed state (failsafe, RC presence, brake steps, Junior
// timeout, L298N dead time) compares Micros, so once expired it stays expired whatever time
// passes: a pulse from 71.6 minutes ago is 71.6 minutes old, not fresh again.
//
// Boards only have a free-running 32-bit microsecond counter (Arduino micros(), a timer), which
// wraps every 2^32 us = 71.6 min. MonotonicClock extends it to Micros; the board loop reads it
// every iteration (>= 1 kHz), and the hardware watchdog resets a board whose loop stops, so the
// counter is never left unread for a whole wrap.
#pragma once
#include <stdint.h>

namespace roar {

using Micros = uint64_t;     // [us] since boot, monotonic, never wraps
using RawMicros = uint32_t;  // [us] a board's free-running hardware counter, wraps every 71.6 min
using DurationUs = uint32_t; // [us] a configured span of time (a timeout, a step), up to 71.6 min

// [us] time from `since` to `now` (both Micros, so no wrap to worry about).
inline Micros elapsed_us(Micros now, Micros since) { return now - since; }

class MonotonicClock {
 public:
  // The raw counter's reading now -> Micros. Exact while consecutive readings are less than
  // 2^32 us apart.
  Micros extend(RawMicros raw) {
    now_ += static_cast<RawMicros>(raw - last_raw_);
    last_raw_ = raw;
    return now_;
  }
  Micros now() const { return now_; }

 private:
  Micros now_ = 0;
  RawMicros last_raw_ = 0;
};

}  // namespace roar
