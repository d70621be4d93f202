#include "roar/failsafe.h"

namespace roar {

bool CommandWatchdog::is_neutral(const ControlCommand& cmd) const {
  const int32_t off = static_cast<int32_t>(cmd.throttle_us) - static_cast<int32_t>(proto::kControlNeutralUs);
  return off <= arm_window_us_ && -off <= arm_window_us_;
}

WatchdogEvent CommandWatchdog::poll(Micros now_us) {
  if (!latched_ && elapsed_us(now_us, last_valid_us_) > timeout_us_) {
    latched_ = true;
    return WatchdogEvent::Tripped;
  }
  return WatchdogEvent::None;
}

bool CommandWatchdog::accept(const ControlCommand& cmd, Micros now_us, WatchdogEvent* event) {
  // A silence that ended with this very command still counts, however rarely poll() runs.
  WatchdogEvent ev = poll(now_us);
  bool drive = true;
  if (latched_) {
    drive = is_neutral(cmd);
    if (drive) {
      latched_ = false;
      ev = WatchdogEvent::Armed;
    }
  }
  if (drive) last_valid_us_ = now_us;
  if (event) *event = ev;
  return drive;
}

}  // namespace roar
