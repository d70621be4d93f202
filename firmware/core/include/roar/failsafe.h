// Command watchdog: when no valid command has arrived for more than the timeout, the car goes
// to neutral/centre and stays there (latched) until a neutral command re-arms it. The car
// boots latched. See protocol/PROTOCOL.md section 2.1.
#pragma once
#include <stdint.h>

#include "roar/clock.h"
#include "roar/control_parser.h"
#include "roar/protocol.h"

namespace roar {

enum class WatchdogEvent : uint8_t {
  None = 0,
  Tripped = 1,  // the timeout expired: the car is now latched
  Armed = 2,    // a neutral command released the latch
};

class CommandWatchdog {
 public:
  explicit CommandWatchdog(DurationUs timeout_us = proto::kTimingFailsafeTimeoutUs,
                           uint16_t arm_window_us = proto::kTimingArmWindowUs)
      : timeout_us_(timeout_us), arm_window_us_(arm_window_us) {}

  // Offer a valid command. Returns true when it may drive the car; *event tells whether this
  // call tripped the watchdog (a silence longer than the timeout just ended) or re-armed it.
  bool accept(const ControlCommand& cmd, Micros now_us, WatchdogEvent* event);

  // Call every loop: returns Tripped once, when the silence exceeds the timeout.
  WatchdogEvent poll(Micros now_us);

  bool latched() const { return latched_; }
  DurationUs timeout_us() const { return timeout_us_; }

 private:
  bool is_neutral(const ControlCommand& cmd) const;

  DurationUs timeout_us_;
  uint16_t arm_window_us_;
  bool latched_ = true;
  Micros last_valid_us_ = 0;
};

}  // namespace roar
