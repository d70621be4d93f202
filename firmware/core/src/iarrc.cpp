#include "roar/iarrc.h"

namespace roar {
namespace {

// (previous AB, new AB) -> +1, -1, 0 (no change) or 2 (both lines changed: an edge was missed).
constexpr int8_t kQuadrature[16] = {0, -1, +1, 2, +1, 0, 2, -1, -1, 2, 0, +1, 2, +1, -1, 0};

}  // namespace

void QuadratureDecoder::update(bool a, bool b) {
  const uint8_t now = static_cast<uint8_t>((a ? 2 : 0) | (b ? 1 : 0));
  const int8_t step = kQuadrature[(last_ << 2) | now];
  if (step == 2) {
    ++errors_;
  } else {
    count_ += step;
  }
  last_ = now;
}

void SpeedEstimator::update(int32_t count, Micros now_us) {
  if (filled_ == 0) first_count_ = count;
  last_count_ = count;
  // The oldest sample kept: the one this update replaces once the window is full (read before
  // it is overwritten), the first one before that.
  const uint8_t oldest = filled_ < kWindow ? 0 : next_;
  const int32_t old_count = counts_[oldest];
  const Micros old_time = times_[oldest];
  const bool have_old = filled_ > 0;
  counts_[next_] = count;
  times_[next_] = now_us;
  next_ = static_cast<uint8_t>((next_ + 1) % kWindow);
  if (filled_ < kWindow) ++filled_;
  if (!have_old) return;
  const Micros dt = now_us - old_time;
  if (dt == 0) return;
  const int64_t counts = static_cast<int64_t>(count) - old_count;
  speed_mm_s_ = static_cast<int32_t>(counts * 1000 * 1000000 / static_cast<int64_t>(counts_per_m_) /
                                     static_cast<int64_t>(dt));
}

int64_t SpeedEstimator::distance_mm() const {
  return (static_cast<int64_t>(last_count_) - first_count_) * 1000 / static_cast<int64_t>(counts_per_m_);
}

int64_t SpeedPid::output_milli(int32_t target, int32_t error, int64_t integral_um, int32_t derivative) const {
  return static_cast<int64_t>(gains_.ff_pm) * target + static_cast<int64_t>(gains_.kp_pm) * error +
         static_cast<int64_t>(gains_.ki_pm) * integral_um / 1000 + static_cast<int64_t>(gains_.kd_pm) * derivative;
}

int32_t SpeedPid::step(int32_t target_mm_s, int32_t measured_mm_s, DurationUs dt_us) {
  const int32_t error = target_mm_s - measured_mm_s;  // [mm/s]
  const int32_t derivative = started_ && dt_us > 0
                                 ? static_cast<int32_t>(static_cast<int64_t>(error - last_error_) * 1000000 / dt_us)
                                 : 0;  // [mm/s^2]
  last_error_ = error;
  started_ = true;
  const int64_t limit = static_cast<int64_t>(max_us_) * 1000;
  const int64_t before = output_milli(target_mm_s, error, integral_um_, derivative);
  // Anti-windup: integrate only while the output is not pushing past its limit in the error's direction.
  const bool saturated_up = before >= limit && error > 0;
  const bool saturated_down = before <= -limit && error < 0;
  if (!saturated_up && !saturated_down) integral_um_ += static_cast<int64_t>(error) * dt_us / 1000;
  int64_t out = output_milli(target_mm_s, error, integral_um_, derivative);
  out = out > limit ? limit : (out < -limit ? -limit : out);
  return static_cast<int32_t>((out >= 0 ? out + 500 : out - 500) / 1000);  // [us], rounded
}

void SpeedPid::reset() {
  integral_um_ = 0;
  last_error_ = 0;
  started_ = false;
}

void BatteryMonitor::update(uint16_t adc_counts) {
  mv_ = static_cast<uint32_t>(static_cast<uint64_t>(adc_counts) * config_.uv_per_count / 1000);
  measured_ = true;
  if (mv_ < config_.cutoff_mv) cutoff_ = true;
  if (cutoff_ && mv_ > config_.cutoff_mv + config_.hysteresis_mv) cutoff_ = false;
}

IarrcController::IarrcController(const IarrcConfig& config)
    : config_(config),
      speed_(config.counts_per_m),
      pid_(config.pid, config.pid_max_us),
      battery_(config.battery),
      brake_(config.brake) {}

ParseResult IarrcController::host_byte(uint8_t byte, Micros now_us) {
  ParseResult r = parser_.feed(byte);
  // Signed control: a refused message (unsigned, forged, replayed; nokey) changes nothing and
  // does not count as hearing the host.
  if (r == ParseResult::Ok || r == ParseResult::Setpoint) r = keys_.auth().check(r, parser_);
  if (r == ParseResult::Setpoint) {
    setpoint_ = parser_.setpoint();
    host_heard_ = true;
    host_last_us_ = now_us;
    if (mode_ == IarrcMode::Failsafe && failsafe_ == IarrcFailsafe::HostSilent && setpoint_.speed_mm_s == 0) {
      host_rearm_ = true;
    }
  }
  return r;
}

bool IarrcController::rc_present(Micros now_us) const {
  return sbus_.locked() && elapsed_us(now_us, sbus_.last_good_us()) <= proto::kRcSignalTimeoutUs;
}

ModeSwitch IarrcController::mode_switch() const {
  const uint16_t us = sbus_raw_to_us(sbus_.frame().raw[config_.mode_channel]);
  return us < config_.switch_low_us ? ModeSwitch::Off
                                    : (us > config_.switch_high_us ? ModeSwitch::Autonomous : ModeSwitch::Manual);
}

bool IarrcController::stop_switch() const {
  return sbus_raw_to_us(sbus_.frame().raw[config_.stop_channel]) > config_.switch_high_us;
}

bool IarrcController::host_fresh(Micros now_us) const {
  return host_heard_ && elapsed_us(now_us, host_last_us_) <= proto::kTimingFailsafeTimeoutUs;
}

void IarrcController::enter(IarrcMode mode, IarrcFailsafe why) {
  if (mode == IarrcMode::Disarmed) switch_seen_off_ = false;
  if (mode != mode_) pid_.reset();
  mode_ = mode;
  failsafe_ = why;
  host_rearm_ = false;
}

void IarrcController::step_mode(Micros now_us) {
  if (mode_ == IarrcMode::Boot) enter(IarrcMode::Disarmed);
  const bool rc = rc_present(now_us);
  const ModeSwitch sw = rc ? mode_switch() : ModeSwitch::Off;
  if (rc && stop_switch()) {
    if (mode_ != IarrcMode::Emergency) enter(IarrcMode::Emergency);
    return;
  }
  const bool driving = mode_ == IarrcMode::Manual || mode_ == IarrcMode::Autonomous;
  if (driving && !rc) return enter(IarrcMode::Failsafe, IarrcFailsafe::RcLost);
  if (driving && battery_.cutoff()) return enter(IarrcMode::Failsafe, IarrcFailsafe::Battery);
  switch (mode_) {
    case IarrcMode::Boot:
      break;
    case IarrcMode::Emergency:
    case IarrcMode::Failsafe:
      if (rc && sw == ModeSwitch::Off) {
        enter(IarrcMode::Disarmed);
        switch_seen_off_ = true;
      } else if (host_rearm_ && rc && sw == ModeSwitch::Autonomous && !battery_.cutoff()) {
        enter(IarrcMode::Autonomous);
      }
      break;
    case IarrcMode::Disarmed:
      if (!rc) {  // a transmitter that comes back must show "off" again before the car drives
        switch_seen_off_ = false;
        break;
      }
      if (sw == ModeSwitch::Off) {
        switch_seen_off_ = true;
      } else if (switch_seen_off_ && !battery_.cutoff()) {
        enter(sw == ModeSwitch::Manual ? IarrcMode::Manual : IarrcMode::Autonomous);
        if (mode_ == IarrcMode::Autonomous && !host_fresh(now_us)) enter(IarrcMode::Failsafe, IarrcFailsafe::HostSilent);
      }
      break;
    case IarrcMode::Manual:
    case IarrcMode::Autonomous:
      if (sw == ModeSwitch::Off) {
        enter(IarrcMode::Disarmed);
        switch_seen_off_ = true;
      } else if (sw == ModeSwitch::Manual && mode_ != IarrcMode::Manual) {
        enter(IarrcMode::Manual);
      } else if (sw == ModeSwitch::Autonomous && mode_ != IarrcMode::Autonomous) {
        enter(IarrcMode::Autonomous);
      }
      if (mode_ == IarrcMode::Autonomous && !host_fresh(now_us)) enter(IarrcMode::Failsafe, IarrcFailsafe::HostSilent);
      break;
  }
}

IarrcOutputs IarrcController::control(Micros now_us, uint32_t frames_started) {
  step_mode(now_us);
  const Micros since = controlled_ ? elapsed_us(now_us, last_control_us_) : 0;
  const DurationUs dt_us = since > 0xFFFFFFFFu ? 0xFFFFFFFFu : static_cast<DurationUs>(since);
  last_control_us_ = now_us;
  controlled_ = true;
  uint16_t throttle = proto::kControlNeutralUs, steering = proto::kControlNeutralUs;
  if (mode_ == IarrcMode::Manual) {
    const SbusFrame& f = sbus_.frame();
    throttle = sbus_raw_to_us(f.raw[config_.throttle_channel]);
    steering = sbus_raw_to_us(f.raw[config_.steering_channel]);
  } else if (mode_ == IarrcMode::Autonomous) {
    // the PID reaches at most pid_max_us (500) either side of neutral: a pulse in 1000..2000
    throttle = static_cast<uint16_t>(proto::kControlNeutralUs + pid_.step(setpoint_.speed_mm_s, speed_.speed_mm_s(), dt_us));
    steering = setpoint_.steering_us;
  }
  throttle = brake_.step(throttle, now_us, frames_started);
  return IarrcOutputs{map_pulse(throttle, config_.throttle), map_pulse(steering, config_.steering), mode_, failsafe_};
}

}  // namespace roar
