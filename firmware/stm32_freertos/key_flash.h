// The two flash sectors the signing key's log lives in (roar/flash_log.h): sectors 1 and 2 of
// the STM32F745 (32 KB each from 0x08008000, kept out of the image by stm32f745.ld), programmed
// a word at a time and erased through the flash interface (RM0385 3.3). An erase (up to ~0.5 s)
// happens only in FlashLog::begin(), before the watchdog starts. The emulator build keeps them in
// RAM (QEMU models no flash interface): blank at every start.
#pragma once
#include <stdint.h>

#include "roar/flash_log.h"

class KeyFlash : public roar::FlashSector {
 public:
  explicit KeyFlash(uint8_t index);  // 0 or 1: the log's first or second sector
  uint32_t size() const override;
  const uint8_t* bytes() const override;
  bool program(uint32_t offset, const uint32_t* words, uint8_t n) override;
  bool erase() override;

 private:
  uint8_t index_;
};
