#include "roar/l298n_mixer.h"

namespace roar {
namespace {

constexpr int32_t kFull = proto::kL298nDutyFullScale;              // [permille]
constexpr int32_t kHalfRange = (proto::kControlMaxUs - proto::kControlMinUs) / 2;  // [us]

// Pulse width -> -kFull..kFull.
int32_t to_permille(uint16_t pulse_us) {
  int32_t v = (static_cast<int32_t>(pulse_us) - proto::kControlNeutralUs) * kFull / kHalfRange;
  return v < -kFull ? -kFull : (v > kFull ? kFull : v);
}

int32_t abs32(int32_t v) { return v < 0 ? -v : v; }

}  // namespace

SideDuties mix_ackermann(uint16_t throttle_us, uint16_t steering_us) {
  const int32_t t = to_permille(throttle_us);
  const int32_t s = to_permille(steering_us);
  int32_t left = t + s;
  int32_t right = t - s;
  const int32_t peak = abs32(left) > abs32(right) ? abs32(left) : abs32(right);
  if (peak > kFull) {
    left = left * kFull / peak;
    right = right * kFull / peak;
  }
  return SideDuties{static_cast<int16_t>(left), static_cast<int16_t>(right)};
}

SidePins L298nSide::step(int16_t duty_permille, Micros now_us, DurationUs dead_time_us) {
  const int8_t want = duty_permille > 0 ? 1 : (duty_permille < 0 ? -1 : 0);
  const SidePins coast = {false, false, 0};
  if (want == 0 || want == -applied_dir_) {  // stop, or reverse: coast first
    if (applied_dir_ != 0) {
      last_dir_ = applied_dir_;
      applied_dir_ = 0;
      coast_since_us_ = now_us;
    }
    return coast;
  }
  if (applied_dir_ == 0) {
    const bool reversing = last_dir_ == -want;
    if (reversing && elapsed_us(now_us, coast_since_us_) < dead_time_us) return coast;
    applied_dir_ = want;
  }
  int32_t mag = duty_permille < 0 ? -static_cast<int32_t>(duty_permille) : duty_permille;
  if (mag > kFull) mag = kFull;
  return SidePins{want > 0, want < 0, static_cast<uint16_t>(mag)};
}

DrivePins L298nDriver::step(const SideDuties& duties, Micros now_us) {
  return DrivePins{left_.step(duties.left, now_us, dead_time_us_), right_.step(duties.right, now_us, dead_time_us_)};
}

}  // namespace roar
