// Emulator benchmark image (QEMU netduinoplus2, STM32F405, Cortex-M4, run with -icount, so
// virtual time advances by a fixed amount per instruction): the core's SbusDecoder fed kFrames
// SBUS frames, timed with SysTick (which counts virtual time; semihosting's SYS_ELAPSED reads
// the host's clock), beside a calibration loop of exactly two instructions per iteration
// (subs, bne). Reports "calibration_ticks N" (for kCalibration iterations), "frame_ticks N"
// (for kFrames frames) and "frames N"; exit status 0 when every frame decoded.
#include <stdint.h>

#include "semihosting.h"

#include "roar/sbus.h"
#include "../sbus_feed.h"

namespace {

constexpr uint8_t kFrames = 50;
constexpr uint32_t kCalibration = 100000;  // iterations of the two-instruction loop

volatile uint32_t* const kSysTick = reinterpret_cast<volatile uint32_t*>(0xE000E010);  // CTRL, LOAD, VAL
constexpr uint32_t kSysTickMask = 0xFFFFFF;  // a 24-bit down-counter

void systick_start() {
  kSysTick[1] = kSysTickMask;  // LOAD
  kSysTick[2] = 0;             // VAL: reload now
  kSysTick[0] = 5;             // CTRL: enable, processor clock, no interrupt
}
uint32_t systick() { return kSysTick[2]; }
uint32_t ticks_since(uint32_t start) { return (start - systick()) & kSysTickMask; }

uint8_t bytes[kFrames][roar::proto::kSbusFrameBytes];
roar::SbusDecoder decoder;

}  // namespace

int main() {
  roar::SbusFrame frame = {};
  for (uint8_t f = 0; f < kFrames; ++f) {
    for (uint8_t c = 0; c < roar::kSbusChannels; ++c) frame.raw[c] = static_cast<uint16_t>(200 + 97 * (f + c) % 1600);
    roar::sbus_encode(frame, bytes[f]);
  }
  systick_start();
  uint32_t start = systick();
  for (uint32_t n = kCalibration; n; --n) __asm__ volatile("" ::: "memory");
  const uint32_t calibration = ticks_since(start);
  start = systick();
  const uint32_t good = feed_sbus_frames<uint32_t>(decoder, bytes);
  const uint32_t frames = ticks_since(start);
  semihosting::say_number("calibration_ticks ", calibration);
  semihosting::say_number("frame_ticks ", frames);
  semihosting::say_number("frames ", good);
  semihosting::leave(good == kFrames ? 0 : 1);
}
