// Brake/reverse sequence for forward/brake/reverse hobby ESCs, non-blocking.
// After any forward output, a reverse command first produces neutral, a slight reverse (the
// "tap" the ESC takes as brake) and neutral again, each for at least step_us and at least one
// output frame, and only then the commanded reverse. See PROTOCOL.md section 2.3.
//
// Invariant: the output never goes from above neutral to below neutral except through
// neutral -> tap -> neutral.
#pragma once
#include <stdint.h>

#include "roar/clock.h"
#include "roar/protocol.h"

namespace roar {

struct BrakeConfig {
  uint16_t neutral_us = proto::kControlNeutralUs;  // [us]
  uint16_t tap_us = proto::kTimingBrakeTapUs;      // [us] slight reverse, below neutral
  DurationUs step_us = proto::kTimingBrakeStepUs;  // [us] minimum duration of each step
};

enum class BrakePhase : uint8_t {
  NeedsSequence = 0,  // a reverse command must go through the sequence first
  Neutral1 = 1,
  Tap = 2,
  Neutral2 = 3,
  ReverseReady = 4,   // the ESC is in reverse mode: reverse passes straight through
};

class BrakeFsm {
 public:
  explicit BrakeFsm(const BrakeConfig& config = BrakeConfig()) : config_(config) {}

  // Throttle pulse to output now for the commanded throttle. `frames_started` counts output
  // frames (pulse periods) started so far; a step only ends once a frame has started after
  // its value reached the output (pass a counter that advances every call when the output
  // has no frames, e.g. a simulation that applies values instantly).
  uint16_t step(uint16_t command_us, Micros now_us, uint32_t frames_started);

  BrakePhase phase() const { return phase_; }

 private:
  void enter(BrakePhase phase, Micros now_us);
  bool step_done(Micros now_us, uint32_t frames_started);

  BrakeConfig config_;
  BrakePhase phase_ = BrakePhase::NeedsSequence;
  Micros phase_start_us_ = 0;
  uint32_t frame_mark_ = 0;
  bool frame_mark_set_ = false;
};

}  // namespace roar
