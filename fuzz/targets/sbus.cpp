// The SBUS decoder (roar/sbus.h) on a byte stream with arrival times: the input is pairs of
// (pause before the byte in units of 25 us, byte), so the frame gap is found or not at will.
// Frames are reported only whole and well formed (raw channels 0..2047, an end byte of SBUS1
// or an SBUS2 slot); the counters only grow, by one per reported frame or drop; every
// 25-byte candidate that decodes encodes back to the same bytes.
#include <string.h>

#include "harness.h"

static bool end_ok(uint8_t end) { return end == 0x00 || end == 0x04 || end == 0x14 || end == 0x24 || end == 0x34; }

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  fuzz::Object decoder(roar_sbus_decoder_size());
  roar_sbus_decoder_init(decoder);
  roar_sbus_status_t before = {}, after = {};
  roar_sbus_frame_t frame;
  uint64_t now_us = 1000;
  for (size_t i = 0; i + 1 < size; i += 2) {
    now_us += 25u * data[i];
    roar_sbus_status(decoder, &before);
    const uint8_t r = roar_sbus_feed(decoder, data[i + 1], now_us);
    roar_sbus_status(decoder, &after);
    CHECK(r < fuzz::kSbusResultCount);
    CHECK(after.good_frames >= before.good_frames && after.dropped >= before.dropped);
    CHECK(after.failsafe_frames >= before.failsafe_frames && after.lost_frames >= before.lost_frames);
    const uint32_t grew = (after.good_frames - before.good_frames) + (after.failsafe_frames - before.failsafe_frames);
    if (r == static_cast<uint8_t>(fuzz::SbusResult::Frame)) {
      CHECK(after.good_frames == before.good_frames + 1);
      roar_sbus_last_frame(decoder, &frame);
      CHECK(end_ok(frame.end) && !frame.failsafe);
      for (uint16_t raw : frame.raw) CHECK(raw <= 2047);
      CHECK(after.last_good_us == now_us);
    } else if (r == static_cast<uint8_t>(fuzz::SbusResult::Dropped)) {
      CHECK(after.dropped > before.dropped);
    } else if (r == static_cast<uint8_t>(fuzz::SbusResult::None)) {
      CHECK(grew == 0);
    }
    if (after.locked) CHECK(after.good_frames >= fuzz::proto::kSbusLockFrames);
  }
  for (size_t i = 0; i + fuzz::proto::kSbusFrameBytes <= size; ++i) {
    if (roar_sbus_decode(data + i, &frame)) {
      uint8_t again[fuzz::proto::kSbusFrameBytes];
      roar_sbus_encode(&frame, again);
      CHECK(memcmp(again, data + i, sizeof again) == 0);
    }
  }
  return 0;
}
