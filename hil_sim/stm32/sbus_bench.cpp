// Emulator benchmark image (QEMU netduinoplus2, STM32F405, Cortex-M4, run with -icount, so
// virtual time advances by a fixed amount per instruction): the core's SbusDecoder fed kFrames
// SBUS frames, timed with SysTick (which counts virtual time; semihosting's SYS_ELAPSED reads
// the host's clock), beside a calibration loop of exactly two instructions per iteration
// (subs, bne). Reports "calibration_ticks N" (for kCalibration
// iterations), "frame_ticks N" (for kFrames frames) and "frames N"; exit status 0 when every
// frame decoded.
#include <stdint.h>

#include "roar/sbus.h"

namespace {

constexpr uint8_t kFrames = 50;
constexpr uint32_t kCalibration = 100000;  // iterations of the two-instruction loop

int semihost(int op, const void* arg) {
  register int r0 __asm__("r0") = op;
  register const void* r1 __asm__("r1") = arg;
  __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
  return r0;
}
void say(const char* text) { semihost(0x04, text); }  // SYS_WRITE0
[[noreturn]] void leave(uint32_t code) {              // SYS_EXIT_EXTENDED
  const uint32_t block[2] = {0x20026, code};
  semihost(0x20, block);
  for (;;) {
  }
}
volatile uint32_t* const kSysTick = reinterpret_cast<volatile uint32_t*>(0xE000E010);  // CTRL, LOAD, VAL
constexpr uint32_t kSysTickMask = 0xFFFFFF;  // a 24-bit down-counter

void systick_start() {
  kSysTick[1] = kSysTickMask;  // LOAD
  kSysTick[2] = 0;             // VAL: reload now
  kSysTick[0] = 5;             // CTRL: enable, processor clock, no interrupt
}
uint32_t systick() { return kSysTick[2]; }
uint32_t ticks_since(uint32_t start) { return (start - systick()) & kSysTickMask; }
void say_number(const char* label, uint32_t value) {
  char text[40];
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

uint8_t bytes[kFrames][roar::proto::kSbusFrameBytes];
roar::SbusDecoder decoder;

__attribute__((noinline)) uint32_t run() {
  uint32_t good = 0;
  roar::Micros now = 100000;
  for (uint8_t f = 0; f < kFrames; ++f) {
    now += 7000 - roar::proto::kSbusFrameBytes * 120;
    for (uint8_t i = 0; i < roar::proto::kSbusFrameBytes; ++i) {
      now += 120;
      if (decoder.feed(bytes[f][i], now) == roar::SbusResult::Frame) ++good;
    }
  }
  return good;
}

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
  const uint32_t good = run();
  const uint32_t frames = ticks_since(start);
  say_number("calibration_ticks ", calibration);
  say_number("frame_ticks ", frames);
  say_number("frames ", good);
  leave(good == kFrames ? 0 : 1);
}
