// L298N differential drive (ROAR Junior): each side's signed duty (from the Junior's HTTP control,
// junior_control.h) drives two direction pins and one PWM duty, with a zero-duty dead time
// whenever that side reverses. See PROTOCOL.md section 2.5.
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
