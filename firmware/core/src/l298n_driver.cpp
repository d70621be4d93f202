#include "roar/l298n_driver.h"

namespace roar {
namespace {

constexpr int32_t kFull = proto::kL298nDutyFullScale;  // [permille]

}  // namespace

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
