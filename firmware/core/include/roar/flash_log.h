// Non-volatile memory on a chip whose only storage is flash erased a whole sector at a time
// (the AnyFC F7's STM32F745: a sector erase takes longer than the loop's watchdog allows).
//
//   FlashSector  what the board lends: a sector read like memory, programmed a 32-bit word at
//                a time (bits go from 1 to 0 only), erased whole to 0xFF (slowly).
//   FlashLog     the Nvm the core keeps in two such sectors: each write appends a new copy of
//                the record, with the next sequence number and a check, in the next blank slot
//                of the sector in use, so the loop never waits for an erase. The newest copy
//                whose check holds is the record: a reset while programming leaves the copy
//                before it. When fewer than kSpareSlots slots are blank, begin() (at boot,
//                before the watchdog starts) erases the other sector, copies the record into
//                it and uses it from then on; the record is never in an erased sector alone,
//                so a power cut at any moment keeps it.
#pragma once
#include <stddef.h>
#include <stdint.h>

#include "roar/signing.h"

namespace roar {

class FlashSector {
 public:
  virtual uint32_t size() const = 0;         // [bytes] a multiple of FlashLog::kSlotBytes
  virtual const uint8_t* bytes() const = 0;  // the sector, as the chip maps it
  // Program words[0..n) at offset (a multiple of 4, every word blank there); false on an error.
  virtual bool program(uint32_t offset, const uint32_t* words, uint8_t n) = 0;
  virtual bool erase() = 0;  // the whole sector to 0xFF; false on an error

 protected:
  ~FlashSector() = default;
};

class FlashLog : public Nvm {
 public:
  static const uint8_t kSlotBytes = 64;              // [bytes] data, sequence number, check
  static const uint8_t kDataBytes = kSlotBytes - 8;  // [bytes] of Nvm offered
  static const uint16_t kSpareSlots = 16;            // blank slots begin() keeps for key changes
  static_assert(KeyRecord::kBytes <= kDataBytes, "the key record fits a slot");

  FlashLog(FlashSector& first, FlashSector& second) : sectors_{&first, &second} {}

  // Boot, before the watchdog starts: finds the newest copy; moves to the other sector (erasing
  // it first) when fewer than kSpareSlots slots of this one are blank.
  void begin();

  void read(uint16_t at, uint8_t* data, uint8_t n) override;
  // A new copy in the next blank slot; none when the sector is full (begin() makes room at the
  // next boot): the record then reads as before, which is how a key change learns it failed.
  void write(uint16_t at, const uint8_t* data, uint8_t n) override;

  uint32_t slots() const { return sectors_[active_]->size() / kSlotBytes; }
  uint32_t blank_slots() const { return slots() - head_; }
  uint8_t active() const { return active_; }  // the sector in use (0 or 1)

 private:
  uint32_t check(const uint8_t* slot) const;  // over the data and the sequence number
  void scan();
  bool append(uint8_t sector, const uint8_t data[kDataBytes]);

  FlashSector* sectors_[2];
  const uint8_t* newest_ = nullptr;  // the newest copy whose check holds (nullptr: none)
  uint32_t sequence_ = 0;            // its sequence number
  uint8_t active_ = 0;               // the sector appended to
  uint32_t head_ = 0;                // its first slot after every slot that is not blank
};

}  // namespace roar
