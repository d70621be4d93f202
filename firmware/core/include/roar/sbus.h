// SBUS receiver frames (FrSky, Futaba): 25 bytes at 100 kbaud 8E2 inverted, the UART doing the
// bit level. SbusDecoder takes the bytes as they arrive and finds the frames in them:
//
//   - a pause of kSbusFrameGapUs between bytes starts a new frame (the receiver's frame gap);
//   - a frame must start with 0x0F, end with 0x00 or an SBUS2 slot byte (0x04/0x14/0x24/0x34)
//     and have no flag bits above the four defined ones; a candidate that fails is not thrown
//     away but searched for the next 0x0F, so a stream that starts mid-frame resynchronises
//     within a frame even with no pauses to go by;
//   - the frame-lost flag is counted, not treated as a failsafe (the receiver skipped one
//     frame); the failsafe flag is honoured, and so is a frame with any of the first four
//     channels at raw 0 (875 us), which no transmitter sends;
//   - the channels are used only once kSbusLockFrames good frames have come in a row, and the
//     lock is lost on a failsafe frame.
//
// Channels are kept raw (0..2047); sbus_raw_to_us() maps raw 200..1800 to 1000..2000 us.
#pragma once
#include <stddef.h>
#include <stdint.h>

#include "roar/clock.h"
#include "roar/protocol.h"

namespace roar {

static const uint8_t kSbusChannels = proto::kSbusChannels;

struct SbusFrame {
  uint16_t raw[kSbusChannels];  // 11-bit channel values
  bool ch17;                    // digital channels
  bool ch18;
  bool frame_lost;  // the receiver skipped a frame before this one
  bool failsafe;    // the receiver's failsafe flag
  uint8_t end;      // the end byte: 0x00, or the SBUS2 slot
};

// [us] of a raw channel value: 875 + raw * 5 / 8.
inline uint16_t sbus_raw_to_us(uint16_t raw) {
  return static_cast<uint16_t>(proto::kSbusUsOffset + raw * proto::kSbusUsPerRawNum / proto::kSbusUsPerRawDen);
}

// The frame's 25 bytes (for tests and simulated transmitters).
void sbus_encode(const SbusFrame& frame, uint8_t out[proto::kSbusFrameBytes]);

// A 25-byte candidate: true and *frame filled when it is a well-formed frame.
bool sbus_decode(const uint8_t in[proto::kSbusFrameBytes], SbusFrame* frame);

// Whether a well-formed frame says the transmitter is gone: the failsafe flag, or a guarded
// channel at raw 0.
bool sbus_is_failsafe(const SbusFrame& frame);

class SbusDecoder {
 public:
  // One received byte, with the time it arrived.
  SbusResult feed(uint8_t byte, Micros now_us);

  const SbusFrame& frame() const { return frame_; }  // the last good frame
  bool locked() const { return good_in_row_ >= proto::kSbusLockFrames; }
  Micros last_good_us() const { return last_good_us_; }

  uint32_t good_frames() const { return good_frames_; }
  uint32_t lost_frames() const { return lost_frames_; }  // good frames that carried frame-lost
  uint32_t failsafe_frames() const { return failsafe_frames_; }
  uint32_t dropped() const { return dropped_; }  // candidates that were not frames, cut partial frames

 private:
  SbusResult finish(Micros now_us);

  uint8_t buf_[proto::kSbusFrameBytes];
  uint8_t len_ = 0;
  bool heard_ = false;
  Micros last_byte_us_ = 0;
  Micros last_good_us_ = 0;
  SbusFrame frame_ = {};
  uint8_t good_in_row_ = 0;
  uint32_t good_frames_ = 0, lost_frames_ = 0, failsafe_frames_ = 0, dropped_ = 0;
};

}  // namespace roar
