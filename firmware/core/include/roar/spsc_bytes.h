// Hands bytes from one execution context to another (a BLE stack task to the main loop) without
// locks or heap: a single-producer single-consumer ring of N bytes (N a power of two, at most
// 2^15). The producer copies the bytes in, then publishes its index with release ordering; the
// consumer loads that index with acquire ordering before it reads the bytes, and hands the
// space back the same way. So the consumer never sees an index before the data it covers, on
// any core. A write goes in whole or not at all: a control message is never cut in two.
//
// GCC's __atomic builtins, not <atomic>, which avr-gcc lacks (only boards with tasks use this).
#pragma once
#include <stddef.h>
#include <stdint.h>

namespace roar {

template <uint16_t N>
class SpscBytes {
  static_assert(N >= 2 && N <= 32768 && (N & (N - 1)) == 0, "N: a power of two, at most 2^15");

 public:
  // Producer only. Returns false, storing nothing, when the n bytes do not all fit.
  bool push(const uint8_t* data, size_t n) {
    uint16_t head = __atomic_load_n(&head_, __ATOMIC_RELAXED);  // only this side writes it
    const uint16_t tail = __atomic_load_n(&tail_, __ATOMIC_ACQUIRE);
    if (n > static_cast<size_t>(N - static_cast<uint16_t>(head - tail))) {
      __atomic_fetch_add(&dropped_, 1u, __ATOMIC_RELAXED);
      return false;
    }
    for (size_t i = 0; i < n; ++i, ++head) buf_[head & (N - 1)] = data[i];
    __atomic_store_n(&head_, head, __ATOMIC_RELEASE);
    return true;
  }

  // Consumer only. Moves up to cap bytes into out; returns how many.
  size_t pop(uint8_t* out, size_t cap) {
    uint16_t tail = __atomic_load_n(&tail_, __ATOMIC_RELAXED);  // only this side writes it
    const uint16_t head = __atomic_load_n(&head_, __ATOMIC_ACQUIRE);
    size_t n = 0;
    for (; n < cap && tail != head; ++n, ++tail) out[n] = buf_[tail & (N - 1)];
    __atomic_store_n(&tail_, tail, __ATOMIC_RELEASE);
    return n;
  }

  // Writes refused because the ring was full (the consumer fell behind).
  uint32_t dropped() const { return __atomic_load_n(&dropped_, __ATOMIC_RELAXED); }

 private:
  uint8_t buf_[N];
  uint16_t head_ = 0;  // bytes pushed (mod 2^16), written by the producer
  uint16_t tail_ = 0;  // bytes popped (mod 2^16), written by the consumer
  uint32_t dropped_ = 0;
};

}  // namespace roar
