#include "roar/brake_fsm.h"

namespace roar {

void BrakeFsm::enter(BrakePhase phase, Micros now_us) {
  phase_ = phase;
  phase_start_us_ = now_us;
  frame_mark_set_ = false;  // marked on the next call, after this phase's value reached the output
}

bool BrakeFsm::step_done(Micros now_us, uint32_t frames_started) {
  if (!frame_mark_set_) {
    frame_mark_ = frames_started;
    frame_mark_set_ = true;
    return false;
  }
  return elapsed_us(now_us, phase_start_us_) >= config_.step_us && frames_started != frame_mark_;
}

uint16_t BrakeFsm::step(uint16_t command_us, Micros now_us, uint32_t frames_started) {
  const uint16_t neutral = config_.neutral_us;
  if (command_us > neutral) {  // forward: always allowed, and the ESC leaves reverse mode
    phase_ = BrakePhase::NeedsSequence;
    return command_us;
  }
  if (command_us == neutral) {  // neutral keeps reverse mode, but cancels a half-done sequence
    if (phase_ != BrakePhase::ReverseReady) phase_ = BrakePhase::NeedsSequence;
    return neutral;
  }
  switch (phase_) {
    case BrakePhase::ReverseReady:
      return command_us;
    case BrakePhase::NeedsSequence:
      enter(BrakePhase::Neutral1, now_us);
      return neutral;
    case BrakePhase::Neutral1:
      if (!step_done(now_us, frames_started)) return neutral;
      enter(BrakePhase::Tap, now_us);
      return config_.tap_us;
    case BrakePhase::Tap:
      if (!step_done(now_us, frames_started)) return config_.tap_us;
      enter(BrakePhase::Neutral2, now_us);
      return neutral;
    case BrakePhase::Neutral2:
      if (!step_done(now_us, frames_started)) return neutral;
      phase_ = BrakePhase::ReverseReady;
      return command_us;
  }
  return neutral;
}

}  // namespace roar
