// SipHash-2-4 (Aumasson and Bernstein, 2012): a keyed 64-bit MAC of a byte string under a
// 128-bit key, the message authentication the signed control mode is built on. Streaming, one
// byte at a time, so a parser can authenticate a message as it arrives without keeping it: 41
// bytes of state, no heap, no tables. Golden vectors: protocol/vectors/siphash24.json.
#pragma once
#include <stddef.h>
#include <stdint.h>

namespace roar {

static const uint8_t kSipKeyBytes = 16;

class SipHash24 {
 public:
  // Start a MAC under key (16 bytes, read as two little-endian 64-bit words).
  void begin(const uint8_t key[kSipKeyBytes]);
  // One more byte of the message.
  void add(uint8_t byte);
  // The MAC of the bytes added since begin(); the object must be begun again to use it again.
  uint64_t finish();

  // The MAC of a whole message at once.
  static uint64_t mac(const uint8_t key[kSipKeyBytes], const uint8_t* data, size_t n);

 private:
  void compress(uint64_t m);

  uint64_t v_[4];
  uint8_t block_[8];  // the bytes of the current 8-byte block so far (no 64-bit shifts per byte)
  uint8_t length_;  // bytes added, modulo 256 (only the low byte enters the MAC)
};

}  // namespace roar
