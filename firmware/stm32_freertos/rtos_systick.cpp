// The task table without an RTOS (the offline build, and the emulated Cortex-M4 in the tests):
// SysTick counts milliseconds; the main loop runs the highest-priority task that is due, to
// completion, then looks again, and sleeps (WFI) when none is. A task still running when its next
// release passes runs again at once, then keeps its period from there, and the releases it missed
// are counted, as FreeRTOS runs it on the board (rtos_freertos.cpp). Tasks do not pre-empt each
// other here, so the lock has nothing to do; only the interrupts run beside them.
#if !ROAR_FREERTOS
#include "registers.h"
#include "rtos.h"

namespace {
volatile uint32_t ticks = 0;  // [ms] since run() began
}

extern "C" void SysTick_Handler() { ticks = ticks + 1; }

namespace rtos {

void lock() {}
void unlock() {}
void critical_enter() { __asm__ volatile("cpsid i" ::: "memory"); }
void critical_exit() { __asm__ volatile("cpsie i" ::: "memory"); }

roar::RawMicros systick_us() {
  uint32_t ms, down;
  do {  // a SysTick interrupt between the two reads would pair a new count with an old one
    ms = ticks;
    down = reg::at(reg::kSysTickVal);
  } while (ms != ticks);
  const uint32_t load = reg::at(reg::kSysTickLoad);
  return ms * 1000u + (load - down) / ((load + 1) / 1000u);
}

void run(roar::IarrcBoard& board) {
  reg::at(reg::kSysTickLoad) = core_hz() / kTickHz - 1;
  reg::at(reg::kSysTickVal) = 0;
  reg::at(reg::kSysTickCtrl) = 7;  // processor clock, interrupt, on
  uint32_t next[roar::kIarrcTaskCount] = {};  // [ms] each task's next release
  for (;;) {
    const uint32_t now = ticks;
    int8_t due = -1;
    for (uint8_t i = 0; i < roar::kIarrcTaskCount; ++i) {
      const bool ready = static_cast<int32_t>(now - next[i]) >= 0;
      if (ready && (due < 0 || roar::kIarrcTasks[i].priority > roar::kIarrcTasks[due].priority)) due = static_cast<int8_t>(i);
    }
    if (due < 0) {
      __asm__ volatile("wfi");
      continue;
    }
    board.run(static_cast<roar::IarrcTask>(due));
    const uint32_t period = roar::kIarrcTasks[due].period_us / (1000000 / kTickHz);
    const uint32_t end = ticks;
    next[due] += period;
    if (static_cast<int32_t>(end - next[due]) >= 0) {  // overran: the next release(s) passed
      board.overran(static_cast<roar::IarrcTask>(due), (end - next[due]) / period + 1);
      next[due] = end;
    }
  }
}

}  // namespace rtos
#endif
