// L298N differential drive (ROAR Junior): Ackermann-style (throttle, steering) pulses mix to
// per-side signed duties; each side then drives two direction pins and one PWM duty, with a
// zero-duty dead time whenever that side reverses. See PROTOCOL.md section 2.5.
#pragma once
#include <stdint.h>

#include "roar/clock.h"
#include "roar/protocol.h"

namespace roar {

// Signed duty per side in permille of full scale: -1000 (full reverse) .. +1000 (full forward).
struct SideDuties {
  int16_t left;
  int16_t right;
};

// left = t + s, right = t - s (t, s in -1..1 from the pulses; steering above neutral turns
// right), scaled down together when either exceeds full scale.
SideDuties mix_ackermann(uint16_t throttle_us, uint16_t steering_us);

struct SidePins {
  bool in1;       // high = this side forward
  bool in2;       // high = this side reverse
  uint16_t duty;  // [permille] 0 .. kL298nDutyFullScale on the enable pin
};

struct DrivePins {
  SidePins left;
  SidePins right;
};

class L298nSide {
 public:
  SidePins step(int16_t duty_permille, Micros now_us, DurationUs dead_time_us);

 private:
  int8_t applied_dir_ = 0;   // direction currently on the pins: -1, 0 (coast), +1
  int8_t last_dir_ = 0;      // direction before the current coast
  Micros coast_since_us_ = 0;
};

class L298nDriver {
 public:
  explicit L298nDriver(DurationUs dead_time_us = proto::kL298nDeadTimeUs) : dead_time_us_(dead_time_us) {}
  DrivePins step(const SideDuties& duties, Micros now_us);

 private:
  DurationUs dead_time_us_;
  L298nSide left_;
  L298nSide right_;
};

}  // namespace roar
