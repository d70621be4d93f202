// RC receiver override: a driver holding a transmitter wins over the host. A channel is
// present after kRcLockPulses consecutive valid pulses and while valid pulses keep coming
// within kRcSignalTimeoutUs. Manual control needs both channels. See PROTOCOL.md section 2.2.
//
// The board glue measures pulse widths (pin-change interrupt + timer) and hands each finished
// pulse to on_pulse() from the main loop, never from the interrupt.
#pragma once
#include <stdint.h>

#include "roar/clock.h"
#include "roar/control_parser.h"
#include "roar/protocol.h"

namespace roar {

enum class RcChannel : uint8_t { Throttle = 0, Steering = 1 };

class RcOverride {
 public:
  void on_pulse(RcChannel channel, uint16_t width_us, Micros now_us);

  // True while both channels are present: manual control wins.
  bool active(Micros now_us) const;

  // The receiver's latest command, clamped to the control range.
  ControlCommand command() const { return ControlCommand{channels_[0].width_us, channels_[1].width_us}; }

 private:
  struct Channel {
    uint16_t width_us = proto::kControlNeutralUs;  // [us] clamped
    Micros last_us = 0;                           // [us] time of the last valid pulse
    uint8_t good = 0;                             // consecutive valid pulses, saturating
  };
  bool present(const Channel& ch, Micros now_us) const;

  Channel channels_[2];
};

}  // namespace roar
