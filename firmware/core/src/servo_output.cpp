#include "roar/servo_output.h"

namespace roar {
namespace {

int32_t clamp(int32_t v, int32_t lo, int32_t hi) { return v < lo ? lo : (v > hi ? hi : v); }

}  // namespace

bool calibration_valid(const ChannelCalibration& cal) {
  const int32_t half = (proto::kControlMaxUs - proto::kControlMinUs) / 2;
  return cal.min_us <= cal.max_us && cal.trim_us < half && -cal.trim_us < half;
}

uint16_t map_pulse(uint16_t command_us, const ChannelCalibration& cal) {
  int32_t v = static_cast<int32_t>(command_us) + cal.trim_us;
  if (cal.min_us <= cal.max_us) v = clamp(v, cal.min_us, cal.max_us);
  return static_cast<uint16_t>(clamp(v, proto::kControlMinUs, proto::kControlMaxUs));
}

}  // namespace roar
