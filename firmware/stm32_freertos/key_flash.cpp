#include "key_flash.h"

#include "registers.h"

namespace {
#if ROAR_EMULATOR
constexpr uint32_t kSectorBytes = 2048;  // [bytes] enough for the tests' boots
uint8_t ram[2][kSectorBytes];
#else
constexpr uint32_t kSectorBytes = 32 * 1024;  // [bytes] sectors 1 and 2 of the F745
constexpr uint32_t kFirstAddress = 0x08008000;  // sector 1 (stm32f745.ld: KEYS)
constexpr uint8_t kFirstSectorNumber = 1;
constexpr uint32_t kFlash = 0x40023C00, kKeyr = 0x04, kSr = 0x0C, kCr = 0x10, kKey1 = 0x45670123, kKey2 = 0xCDEF89AB;
constexpr uint32_t kCrPg = 1u << 0, kCrSer = 1u << 1, kCrSnbShift = 3, kCrPsize32 = 2u << 8, kCrStrt = 1u << 16,
                   kCrLock = 1u << 31, kSrBusy = 1u << 16, kSrErrors = 0xF2;  // OPERR WRPERR PGAERR PGPERR ERSERR

void start(uint32_t control) {  // unlocked (it locks again after each operation), then the command
  reg::at(kFlash + kKeyr) = kKey1;
  reg::at(kFlash + kKeyr) = kKey2;
  reg::at(kFlash + kCr) = control;
}

// Waits out the operation (the CPU stalls on its own fetches meanwhile: one bank); false on an error.
bool done() {
  __asm__ volatile("dsb" ::: "memory");
  while (reg::at(kFlash + kSr) & kSrBusy) {
  }
  const uint32_t errors = reg::at(kFlash + kSr) & kSrErrors;
  reg::at(kFlash + kSr) = errors;  // cleared by writing 1
  reg::at(kFlash + kCr) = kCrLock;
  return errors == 0;
}
#endif
}  // namespace

KeyFlash::KeyFlash(uint8_t index) : index_(index) {
#if ROAR_EMULATOR
  for (uint8_t& b : ram[index_]) b = 0xFF;
#endif
}

uint32_t KeyFlash::size() const { return kSectorBytes; }

const uint8_t* KeyFlash::bytes() const {
#if ROAR_EMULATOR
  return ram[index_];
#else
  return reinterpret_cast<const uint8_t*>(kFirstAddress + index_ * kSectorBytes);
#endif
}

bool KeyFlash::program(uint32_t offset, const uint32_t* words, uint8_t n) {
#if ROAR_EMULATOR
  for (uint8_t i = 0; i < n; ++i) {
    for (uint8_t b = 0; b < 4; ++b) ram[index_][offset + 4u * i + b] &= static_cast<uint8_t>(words[i] >> (8 * b));
  }
  return true;
#else
  for (uint8_t i = 0; i < n; ++i) {
    start(kCrPsize32 | kCrPg);
    *reinterpret_cast<volatile uint32_t*>(kFirstAddress + index_ * kSectorBytes + offset + 4u * i) = words[i];
    if (!done()) return false;
  }
  return true;
#endif
}

bool KeyFlash::erase() {
#if ROAR_EMULATOR
  for (uint8_t& b : ram[index_]) b = 0xFF;
  return true;
#else
  start(kCrPsize32 | kCrSer | (static_cast<uint32_t>(kFirstSectorNumber + index_) << kCrSnbShift));
  reg::at(kFlash + kCr) |= kCrStrt;
  return done();
#endif
}
