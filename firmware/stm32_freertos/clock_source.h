// The board's free-running microsecond counter (roar::Hal::now_us). The DWT cycle counter is
// preferred (no peripheral, cycle accuracy), but on a Cortex-M7 it counts only after its lock
// access register is unlocked, and a part, a debugger or an emulator may leave it stopped: it is
// checked at boot, and TIM2, a 32-bit timer at 1 MHz, is used when it does not advance.
#pragma once
#include <stdint.h>

#include "roar/clock.h"

namespace clock_source {

enum class Source : uint8_t { CycleCounter, Timer2 };

Source begin(uint32_t core_hz);  // call once at boot, before now_us()
roar::RawMicros now_us();

}  // namespace clock_source
