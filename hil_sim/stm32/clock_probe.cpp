// Emulator test image (QEMU netduinoplus2, STM32F405, Cortex-M4): runs the AnyFC F7 board's own
// clock_source code and reports over semihosting which counter it chose and whether the
// microsecond clock it gives advances and never steps back. QEMU does not model the DWT cycle
// counter, so this is where the fallback to TIM2 is proved. Exit status 0 when the clock is good.
#include <stdint.h>

#include "semihosting.h"

#include "clock_source.h"

namespace {

constexpr uint32_t kCoreHz = 16000000;  // [Hz] HSI after reset, as on the F745
constexpr uint32_t kReadings = 20000;


}  // namespace

int main() {
  const clock_source::Source source = clock_source::begin(kCoreHz);
  semihosting::say(source == clock_source::Source::CycleCounter ? "clock cycle-counter\n" : "clock timer2\n");
  const roar::RawMicros first = clock_source::now_us();
  roar::RawMicros last = first;
  uint32_t backwards = 0;
  for (uint32_t i = 0; i < kReadings; ++i) {
    const roar::RawMicros now = clock_source::now_us();
    if (static_cast<int32_t>(now - last) < 0) ++backwards;
    last = now;
  }
  semihosting::say_number("advanced_us ", last - first);
  semihosting::say_number("backwards ", backwards);
  semihosting::leave(last != first && backwards == 0 ? 0 : 1);
}
