// Pulse-width output mapping for one servo/ESC channel: trim, per-channel end-points, then a
// hard clamp to the control range that no configuration can widen. See PROTOCOL.md 2.4.
#pragma once
#include <stdint.h>

#include "roar/protocol.h"

namespace roar {

struct ChannelCalibration {
  int16_t trim_us = 0;                     // [us] added to the commanded pulse
  uint16_t min_us = proto::kControlMinUs;  // [us] lowest pulse this channel may output
  uint16_t max_us = proto::kControlMaxUs;  // [us] highest pulse this channel may output
};

// True when min_us <= max_us and the trim moves neutral by less than half the range.
bool calibration_valid(const ChannelCalibration& cal);

// The pulse to put on the wire for a commanded pulse. Always within
// [kControlMinUs, kControlMaxUs], even for an invalid calibration.
uint16_t map_pulse(uint16_t command_us, const ChannelCalibration& cal);

}  // namespace roar
