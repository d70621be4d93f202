// Semihosting for the QEMU test images: lines to the emulator's console (QEMU writes them to
// its stderr) and an exit status that becomes QEMU's (SYS_EXIT_EXTENDED).
#pragma once
#include <stdint.h>

namespace semihosting {

inline int call(int op, const void* arg) {
  register int r0 __asm__("r0") = op;
  register const void* r1 __asm__("r1") = arg;
  __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
  return r0;
}

inline void say(const char* text) { call(0x04, text); }  // SYS_WRITE0

[[noreturn]] inline void leave(uint32_t code) {
  const uint32_t block[2] = {0x20026, code};  // ADP_Stopped_ApplicationExit
  call(0x20, block);
  for (;;) {
  }
}

// "<label><value>\n"
inline void say_number(const char* label, uint32_t value) {
  char text[48];
  char digits[11];
  int n = 0;
  do {
    digits[n++] = static_cast<char>('0' + value % 10);
    value /= 10;
  } while (value);
  int i = 0;
  for (const char* c = label; *c && i < 34; ++c) text[i++] = *c;
  while (n) text[i++] = digits[--n];
  text[i++] = '\n';
  text[i] = '\0';
  say(text);
}

}  // namespace semihosting
