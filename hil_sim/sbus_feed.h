// The SBUS decoder benchmarks' timed loop, the same on the ATmega328P (avr/parser_bench.cpp)
// and the Cortex-M4 (stm32/sbus_bench.cpp): `count` frames of 25 bytes, 120 us a byte (100 kbaud,
// 8E2), one frame every 7 ms. Returns how many decoded as good frames.
#pragma once
#include <stdint.h>

#include "roar/sbus.h"

template <typename Count, uint8_t kCount>
__attribute__((noinline)) Count feed_sbus_frames(roar::SbusDecoder& decoder,
                                                 const uint8_t (&frames)[kCount][roar::proto::kSbusFrameBytes]) {
  Count good = 0;
  roar::Micros now = 100000;
  for (uint8_t f = 0; f < kCount; ++f) {
    now += 7000 - roar::proto::kSbusFrameBytes * 120;  // the gap before each frame
    for (uint8_t i = 0; i < roar::proto::kSbusFrameBytes; ++i) {
      now += 120;
      if (decoder.feed(frames[f][i], now) == roar::SbusResult::Frame) ++good;
    }
  }
  return good;
}
