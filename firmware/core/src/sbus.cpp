#include "roar/sbus.h"

namespace roar {
namespace {

constexpr uint8_t kBits = proto::kSbusChannelBits;
constexpr uint16_t kMask = (1u << kBits) - 1;
constexpr uint8_t kFlagsAt = 1 + (kSbusChannels * kBits) / 8;  // byte 23
constexpr uint8_t kEndAt = proto::kSbusFrameBytes - 1;         // byte 24
constexpr uint8_t kKnownFlags = proto::kSbusFlagCh17 | proto::kSbusFlagCh18 | proto::kSbusFlagFrameLost |
                                proto::kSbusFlagFailsafe;

bool valid_end(uint8_t end) {
  if (end == proto::kSbusEndByte) return true;
  for (uint8_t i = 0; i < proto::kSbusSbus2EndCount; ++i) {
    if (end == proto::kSbusSbus2EndFirst + i * proto::kSbusSbus2EndStep) return true;
  }
  return false;
}

}  // namespace

void sbus_encode(const SbusFrame& frame, uint8_t out[proto::kSbusFrameBytes]) {
  for (uint8_t i = 0; i < proto::kSbusFrameBytes; ++i) out[i] = 0;
  out[0] = proto::kSbusStartByte;
  uint32_t acc = 0;  // bits not yet written, least significant first
  uint8_t have = 0, at = 1;
  for (uint8_t ch = 0; ch < kSbusChannels; ++ch) {
    acc |= static_cast<uint32_t>(frame.raw[ch] & kMask) << have;
    have += kBits;
    while (have >= 8) {
      out[at++] = static_cast<uint8_t>(acc);
      acc >>= 8;
      have -= 8;
    }
  }
  out[kFlagsAt] = static_cast<uint8_t>((frame.ch17 ? proto::kSbusFlagCh17 : 0) | (frame.ch18 ? proto::kSbusFlagCh18 : 0) |
                                       (frame.frame_lost ? proto::kSbusFlagFrameLost : 0) |
                                       (frame.failsafe ? proto::kSbusFlagFailsafe : 0));
  out[kEndAt] = frame.end;
}

bool sbus_decode(const uint8_t in[proto::kSbusFrameBytes], SbusFrame* frame) {
  const uint8_t flags = in[kFlagsAt];
  if (in[0] != proto::kSbusStartByte || !valid_end(in[kEndAt]) || (flags & ~kKnownFlags)) return false;
  uint32_t acc = 0;
  uint8_t have = 0, at = 1;
  for (uint8_t ch = 0; ch < kSbusChannels; ++ch) {
    while (have < kBits) {
      acc |= static_cast<uint32_t>(in[at++]) << have;
      have += 8;
    }
    frame->raw[ch] = static_cast<uint16_t>(acc & kMask);
    acc >>= kBits;
    have -= kBits;
  }
  frame->ch17 = flags & proto::kSbusFlagCh17;
  frame->ch18 = flags & proto::kSbusFlagCh18;
  frame->frame_lost = flags & proto::kSbusFlagFrameLost;
  frame->failsafe = flags & proto::kSbusFlagFailsafe;
  frame->end = in[kEndAt];
  return true;
}

bool sbus_is_failsafe(const SbusFrame& frame) {
  if (frame.failsafe) return true;
  for (uint8_t ch = 0; ch < proto::kSbusGuardChannels; ++ch) {
    if (frame.raw[ch] == 0) return true;
  }
  return false;
}

SbusResult SbusDecoder::feed(uint8_t byte, Micros now_us) {
  SbusResult result = SbusResult::None;
  if (len_ > 0 && heard_ && elapsed_us(now_us, last_byte_us_) >= proto::kSbusFrameGapUs) {
    len_ = 0;  // a pause: whatever came before was not a whole frame
    ++dropped_;
    result = SbusResult::Dropped;
  }
  heard_ = true;
  last_byte_us_ = now_us;
  if (len_ == 0 && byte != proto::kSbusStartByte) return result;  // between frames
  buf_[len_++] = byte;
  return len_ == proto::kSbusFrameBytes ? finish(now_us) : result;
}

SbusResult SbusDecoder::finish(Micros now_us) {
  SbusFrame candidate;
  if (!sbus_decode(buf_, &candidate)) {
    ++dropped_;
    uint8_t next = 1;  // keep what follows the next start byte: it may be the real frame
    while (next < len_ && buf_[next] != proto::kSbusStartByte) ++next;
    for (uint8_t i = next; i < len_; ++i) buf_[i - next] = buf_[i];
    len_ = static_cast<uint8_t>(len_ - next);
    return SbusResult::Dropped;
  }
  len_ = 0;
  if (sbus_is_failsafe(candidate)) {
    ++failsafe_frames_;
    good_in_row_ = 0;
    return SbusResult::Failsafe;
  }
  frame_ = candidate;
  ++good_frames_;
  if (candidate.frame_lost) ++lost_frames_;
  if (good_in_row_ < proto::kSbusLockFrames) ++good_in_row_;
  last_good_us_ = now_us;
  return SbusResult::Frame;
}

}  // namespace roar
