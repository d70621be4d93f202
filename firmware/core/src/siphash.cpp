#include "roar/siphash.h"

#include <string.h>

namespace roar {

namespace {

__attribute__((always_inline)) inline uint64_t rotl(uint64_t x, uint8_t b) { return (x << b) | (x >> (64 - b)); }

// Eight bytes as a little-endian word: a copy where the chip is little-endian (AVR, ARM, x86),
// shifts elsewhere.
inline uint64_t load64(const uint8_t* p) {
  uint64_t x = 0;
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
  memcpy(&x, p, sizeof(x));
#else
  for (uint8_t i = 8; i-- > 0;) x = (x << 8) | p[i];
#endif
  return x;
}

__attribute__((always_inline)) inline void sip_round(uint64_t v[4]) {
  v[0] += v[1];
  v[1] = rotl(v[1], 13);
  v[1] ^= v[0];
  v[0] = rotl(v[0], 32);
  v[2] += v[3];
  v[3] = rotl(v[3], 16);
  v[3] ^= v[2];
  v[0] += v[3];
  v[3] = rotl(v[3], 21);
  v[3] ^= v[0];
  v[2] += v[1];
  v[1] = rotl(v[1], 17);
  v[1] ^= v[2];
  v[2] = rotl(v[2], 32);
}

}  // namespace

void SipHash24::begin(const uint8_t key[kSipKeyBytes]) {
  const uint64_t k0 = load64(key), k1 = load64(key + 8);
  v_[0] = k0 ^ 0x736f6d6570736575ULL;  // "somepseu"
  v_[1] = k1 ^ 0x646f72616e646f6dULL;  // "dorandom"
  v_[2] = k0 ^ 0x6c7967656e657261ULL;  // "lygenera"
  v_[3] = k1 ^ 0x7465646279746573ULL;  // "tedbytes"
  length_ = 0;
}

void SipHash24::compress(uint64_t m) {
  v_[3] ^= m;
  sip_round(v_);
  sip_round(v_);
  v_[0] ^= m;
}

void SipHash24::add(uint8_t byte) {
  block_[length_ & 7] = byte;
  ++length_;
  if ((length_ & 7) == 0) compress(load64(block_));
}

uint64_t SipHash24::finish() {
  for (uint8_t i = length_ & 7; i < 7; ++i) block_[i] = 0;
  block_[7] = length_;  // the length's low byte ends the last block
  compress(load64(block_));
  v_[2] ^= 0xff;
  for (uint8_t i = 0; i < 4; ++i) sip_round(v_);
  return v_[0] ^ v_[1] ^ v_[2] ^ v_[3];
}

uint64_t SipHash24::mac(const uint8_t key[kSipKeyBytes], const uint8_t* data, size_t n) {
  SipHash24 h;
  h.begin(key);
  for (size_t i = 0; i < n; ++i) h.add(data[i]);
  return h.finish();
}

}  // namespace roar
