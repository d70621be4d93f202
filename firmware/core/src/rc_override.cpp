#include "roar/rc_override.h"

namespace roar {

void RcOverride::on_pulse(RcChannel channel, uint16_t width_us, Micros now_us) {
  Channel& ch = channels_[static_cast<uint8_t>(channel) & 1u];
  if (width_us < proto::kRcPulseMinValidUs || width_us > proto::kRcPulseMaxValidUs) {
    ch.good = 0;
    return;
  }
  if (ch.good > 0 && elapsed_us(now_us, ch.last_us) > proto::kRcSignalTimeoutUs) ch.good = 0;
  if (ch.good < proto::kRcLockPulses) ++ch.good;
  ch.last_us = now_us;
  ch.width_us = width_us < proto::kControlMinUs   ? proto::kControlMinUs
                : width_us > proto::kControlMaxUs ? proto::kControlMaxUs
                                                  : width_us;
}

bool RcOverride::present(const Channel& ch, Micros now_us) const {
  return ch.good >= proto::kRcLockPulses && elapsed_us(now_us, ch.last_us) <= proto::kRcSignalTimeoutUs;
}

bool RcOverride::active(Micros now_us) const {
  return present(channels_[0], now_us) && present(channels_[1], now_us);
}

}  // namespace roar
