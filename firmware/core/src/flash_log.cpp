#include "roar/flash_log.h"

#include "roar/siphash.h"

namespace roar {

namespace {
const uint8_t kZeroKey[kSipKeyBytes] = {};
const uint8_t kSequenceAt = FlashLog::kDataBytes;  // [bytes] into a slot
const uint8_t kCheckAt = FlashLog::kDataBytes + 4;

uint32_t word_at(const uint8_t* p) {
  return p[0] | static_cast<uint32_t>(p[1]) << 8 | static_cast<uint32_t>(p[2]) << 16 | static_cast<uint32_t>(p[3]) << 24;
}

bool blank(const uint8_t* slot) {
  for (uint8_t i = 0; i < FlashLog::kSlotBytes; ++i) {
    if (slot[i] != 0xFF) return false;
  }
  return true;
}
}  // namespace

uint32_t FlashLog::check(const uint8_t* slot) const {
  return static_cast<uint32_t>(SipHash24::mac(kZeroKey, slot, kCheckAt));
}

void FlashLog::scan() {
  newest_ = nullptr;
  sequence_ = 0;
  uint32_t heads[2] = {0, 0};
  for (uint8_t s = 0; s < 2; ++s) {
    const uint8_t* base = sectors_[s]->bytes();
    for (uint32_t slot = 0; slot < sectors_[s]->size() / kSlotBytes; ++slot) {
      const uint8_t* p = base + slot * kSlotBytes;
      if (blank(p)) continue;
      heads[s] = slot + 1;  // a torn copy is skipped, never written over
      const uint32_t sequence = word_at(p + kSequenceAt);
      if (word_at(p + kCheckAt) == check(p) && sequence != 0xFFFFFFFFu && (newest_ == nullptr || sequence > sequence_)) {
        newest_ = p;
        sequence_ = sequence;
        active_ = s;
      }
    }
  }
  head_ = heads[active_];
}

void FlashLog::begin() {
  scan();
  if (blank_slots() >= kSpareSlots) return;
  if (newest_ == nullptr) {  // nothing to keep
    if (sectors_[active_]->erase()) scan();
    return;
  }
  uint8_t keep[kDataBytes];
  read(0, keep, kDataBytes);
  const uint8_t other = active_ ^ 1;
  if (sectors_[other]->erase()) append(other, keep);  // it held only older copies; the old sector waits
}

void FlashLog::read(uint16_t at, uint8_t* data, uint8_t n) {
  for (uint8_t i = 0; i < n; ++i) data[i] = newest_ != nullptr && at + i < kDataBytes ? newest_[at + i] : 0xFF;
}

void FlashLog::write(uint16_t at, const uint8_t* data, uint8_t n) {
  uint8_t copy[kDataBytes];
  read(0, copy, kDataBytes);
  for (uint8_t i = 0; i < n && at + i < kDataBytes; ++i) copy[at + i] = data[i];
  append(active_, copy);
}

bool FlashLog::append(uint8_t sector, const uint8_t data[kDataBytes]) {
  const uint32_t head = sector == active_ ? head_ : 0;  // the other sector: just erased
  if (head >= sectors_[sector]->size() / kSlotBytes || sequence_ >= 0xFFFFFFFEu) return false;  // full
  if (sector == active_) head_ = head + 1;  // used even if programming fails: never programmed twice
  uint8_t slot[kSlotBytes];
  for (uint8_t i = 0; i < kDataBytes; ++i) slot[i] = data[i];
  const uint32_t sequence = sequence_ + 1;
  for (uint8_t i = 0; i < 4; ++i) slot[kSequenceAt + i] = static_cast<uint8_t>(sequence >> (8 * i));
  const uint32_t sum = check(slot);
  for (uint8_t i = 0; i < 4; ++i) slot[kCheckAt + i] = static_cast<uint8_t>(sum >> (8 * i));
  uint32_t words[kSlotBytes / 4];
  for (uint8_t i = 0; i < kSlotBytes / 4; ++i) words[i] = word_at(slot + 4 * i);
  // In order, the check last: a copy cut short anywhere does not count.
  if (!sectors_[sector]->program(head * kSlotBytes, words, kSlotBytes / 4)) return false;
  const uint8_t* written = sectors_[sector]->bytes() + head * kSlotBytes;
  if (word_at(written + kCheckAt) != check(written)) return false;  // read back
  newest_ = written;
  sequence_ = sequence;
  active_ = sector;
  head_ = head + 1;
  return true;
}

}  // namespace roar
