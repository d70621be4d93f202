#include "clock_source.h"

#include "registers.h"

namespace clock_source {
namespace {

constexpr uint32_t kCheckSpins = 64;  // [loop turns] at least a few hundred cycles
Source source = Source::Timer2;
uint32_t cycles_per_us = 1;
uint64_t cycles = 0;  // the cycle counter extended to 64 bits (it wraps in 20 s at 216 MHz)
uint32_t last_cycles = 0;

bool cycle_counter_runs() {
  reg::at(reg::kDemcr) |= reg::kDemcrTrcena;
  reg::at(reg::kDwtLar) = reg::kDwtUnlockKey;  // Cortex-M7: writes to the DWT are ignored until this
  reg::at(reg::kDwtCyccnt) = 0;
  reg::at(reg::kDwtCtrl) |= reg::kDwtCyccntEna;
  const uint32_t before = reg::at(reg::kDwtCyccnt);
  for (volatile uint32_t i = 0; i < kCheckSpins; ++i) {
  }
  return reg::at(reg::kDwtCyccnt) != before;
}

void start_timer2(uint32_t core_hz) {  // APB1 timers run at the core clock straight after reset
  reg::at(reg::kRcc + reg::kApb1Enr) |= reg::kApb1Tim2;
  reg::at(reg::kTim2 + reg::kPsc) = core_hz / 1000000 - 1;  // 1 us per count
  reg::at(reg::kTim2 + reg::kArr) = 0xFFFFFFFFu;            // free-running over all 32 bits
  reg::at(reg::kTim2 + reg::kEgr) = 1;                      // load the prescaler now
  reg::at(reg::kTim2 + reg::kCr1) = 1;
}

}  // namespace

Source begin(uint32_t core_hz) {
  cycles_per_us = core_hz / 1000000;
  if (cycle_counter_runs()) {
    source = Source::CycleCounter;
    last_cycles = reg::at(reg::kDwtCyccnt);
  } else {
    source = Source::Timer2;
    start_timer2(core_hz);
  }
  return source;
}

roar::RawMicros now_us() {
  if (source == Source::Timer2) return reg::at(reg::kTim2 + reg::kCnt);
  // Tasks and the SBUS interrupt both read the clock: the extension must not be split.
  uint32_t primask;
  __asm__ volatile("mrs %0, primask\n cpsid i" : "=r"(primask)::"memory");
  const uint32_t c = reg::at(reg::kDwtCyccnt);
  cycles += static_cast<uint32_t>(c - last_cycles);
  last_cycles = c;
  const uint64_t now = cycles;
  __asm__ volatile("msr primask, %0" ::"r"(primask) : "memory");
  return static_cast<roar::RawMicros>(now / cycles_per_us);
}

}  // namespace clock_source
