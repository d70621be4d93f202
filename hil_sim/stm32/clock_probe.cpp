// Emulator test image (QEMU netduinoplus2, STM32F405, Cortex-M4): runs the AnyFC F7 board's own
// clock_source code and reports over semihosting which counter it chose and whether the
// microsecond clock it gives advances and never steps back. QEMU does not model the DWT cycle
// counter, so this is where the fallback to TIM2 is proved. Exit status 0 when the clock is good.
#include <stdint.h>

#include "clock_source.h"

namespace {

constexpr uint32_t kCoreHz = 16000000;  // [Hz] HSI after reset, as on the F745
constexpr uint32_t kReadings = 20000;

int semihost(int op, const void* arg) {
  register int r0 __asm__("r0") = op;
  register const void* r1 __asm__("r1") = arg;
  __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
  return r0;
}
void say(const char* text) { semihost(0x04, text); }  // SYS_WRITE0
[[noreturn]] void leave(uint32_t code) {              // SYS_EXIT_EXTENDED
  const uint32_t block[2] = {0x20026, code};           // ADP_Stopped_ApplicationExit
  semihost(0x20, block);
  for (;;) {
  }
}
void say_number(const char* label, uint32_t value) {
  char text[32];
  char digits[11];
  int n = 0;
  do {
    digits[n++] = static_cast<char>('0' + value % 10);
    value /= 10;
  } while (value);
  int i = 0;
  for (const char* c = label; *c; ++c) text[i++] = *c;
  while (n) text[i++] = digits[--n];
  text[i++] = '\n';
  text[i] = '\0';
  say(text);
}

}  // namespace

int main() {
  const clock_source::Source source = clock_source::begin(kCoreHz);
  say(source == clock_source::Source::CycleCounter ? "clock cycle-counter\n" : "clock timer2\n");
  const roar::RawMicros first = clock_source::now_us();
  roar::RawMicros last = first;
  uint32_t backwards = 0;
  for (uint32_t i = 0; i < kReadings; ++i) {
    const roar::RawMicros now = clock_source::now_us();
    if (static_cast<int32_t>(now - last) < 0) ++backwards;
    last = now;
  }
  say_number("advanced_us ", last - first);
  say_number("backwards ", backwards);
  leave(last != first && backwards == 0 ? 0 : 1);
}
