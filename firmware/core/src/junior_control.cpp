#include "roar/junior_control.h"

#include "roar/text.h"

namespace roar {
bool parse_unit_permille(const char* text, size_t length, uint16_t* permille) {
  uint32_t whole = 0, fraction = 0, scale = 1000;
  size_t i = 0;
  bool digits = false;
  for (; i < length && text[i] >= '0' && text[i] <= '9'; ++i) {
    whole = whole * 10u + static_cast<uint32_t>(text[i] - '0');
    digits = true;
    if (whole > 1) return false;
  }
  if (i < length && text[i] == '.') {
    for (++i; i < length && text[i] >= '0' && text[i] <= '9'; ++i) {
      digits = true;
      if (scale > 1) {
        scale /= 10u;
        fraction += static_cast<uint32_t>(text[i] - '0') * scale;
      }
    }
  }
  if (!digits || i != length) return false;
  const uint32_t value = whole * 1000u + fraction;
  if (value > proto::kL298nDutyFullScale) return false;
  *permille = static_cast<uint16_t>(value);
  return true;
}

JuniorQueryResult JuniorControl::apply_query(const char* query, size_t length, Micros now_us) {
  JuniorQueryResult result{0, 0};
  heard_ = true;
  last_request_us_ = now_us;
  size_t start = 0;
  while (start < length) {
    size_t end = start;
    while (end < length && query[end] != '&') ++end;
    size_t eq = start;
    while (eq < end && query[eq] != '=') ++eq;
    const char* name = query + start;
    const size_t name_len = eq - start;
    const char* value = eq < end ? query + eq + 1 : query + end;
    const size_t value_len = eq < end ? end - eq - 1 : 0;
    bool ok = false;
    const bool flag = equals(value, value_len, proto::kJuniorFlagTrue);
    if (equals(name, name_len, proto::kJuniorParamForward)) {
      if ((ok = flag)) motion_ = JuniorMotion::Forward;
    } else if (equals(name, name_len, proto::kJuniorParamBackward)) {
      if ((ok = flag)) motion_ = JuniorMotion::Backward;
    } else if (equals(name, name_len, proto::kJuniorParamStop)) {
      if ((ok = flag)) motion_ = JuniorMotion::Stop;
    } else if (equals(name, name_len, proto::kJuniorParamTurnLeft)) {
      if ((ok = flag)) motion_ = JuniorMotion::TurnLeft;
    } else if (equals(name, name_len, proto::kJuniorParamTurnRight)) {
      if ((ok = flag)) motion_ = JuniorMotion::TurnRight;
    } else if (equals(name, name_len, proto::kJuniorParamLeftSpeed)) {
      ok = parse_unit_permille(value, value_len, &left_);
    } else if (equals(name, name_len, proto::kJuniorParamRightSpeed)) {
      ok = parse_unit_permille(value, value_len, &right_);
    }
    if (name_len > 0) {
      if (ok) {
        ++result.applied;
      } else {
        ++result.ignored;
      }
    }
    start = end + 1;
  }
  return result;
}

bool JuniorControl::timed_out(Micros now_us) const {
  return !heard_ || elapsed_us(now_us, last_request_us_) > proto::kJuniorFailsafeTimeoutUs;
}

SideDuties JuniorControl::duties(Micros now_us) const {
  if (timed_out(now_us)) return SideDuties{0, 0};
  const int16_t l = static_cast<int16_t>(left_), r = static_cast<int16_t>(right_);
  switch (motion_) {
    case JuniorMotion::Forward: return SideDuties{l, r};
    case JuniorMotion::Backward: return SideDuties{static_cast<int16_t>(-l), static_cast<int16_t>(-r)};
    case JuniorMotion::TurnLeft: return SideDuties{static_cast<int16_t>(-l), r};
    case JuniorMotion::TurnRight: return SideDuties{l, static_cast<int16_t>(-r)};
    case JuniorMotion::Stop: break;
  }
  return SideDuties{0, 0};
}

}  // namespace roar
