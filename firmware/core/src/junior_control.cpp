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

namespace {

struct Param {
  const char* name;
  size_t name_len;
  const char* value;
  size_t value_len;
};

Param param_at(const char* query, size_t start, size_t end) {
  size_t eq = start;
  while (eq < end && query[eq] != '=') ++eq;
  return Param{query + start, eq - start, eq < end ? query + eq + 1 : query + end, eq < end ? end - eq - 1 : 0};
}

const char* const kFlags[] = {proto::kJuniorParamForward, proto::kJuniorParamBackward, proto::kJuniorParamStop,
                              proto::kJuniorParamTurnLeft, proto::kJuniorParamTurnRight};
const JuniorMotion kFlagMotion[] = {JuniorMotion::Forward, JuniorMotion::Backward, JuniorMotion::Stop,
                                    JuniorMotion::TurnLeft, JuniorMotion::TurnRight};

int flag_index(const Param& p) {
  for (int i = 0; i < 5; ++i) {
    if (equals(p.name, p.name_len, kFlags[i])) return i;
  }
  return -1;
}

// What is wrong with one parameter (None when it can be applied).
JuniorQueryError check(const Param& p) {
  if (flag_index(p) >= 0) {
    const bool ok = equals(p.value, p.value_len, proto::kJuniorFlagTrue) ||
                    equals(p.value, p.value_len, proto::kJuniorFlagFalse);
    return ok ? JuniorQueryError::None : JuniorQueryError::BadFlag;
  }
  if (equals(p.name, p.name_len, proto::kJuniorParamLeftSpeed) ||
      equals(p.name, p.name_len, proto::kJuniorParamRightSpeed)) {
    uint16_t unused;
    return parse_unit_permille(p.value, p.value_len, &unused) ? JuniorQueryError::None : JuniorQueryError::BadSpeed;
  }
  return JuniorQueryError::UnknownName;
}

}  // namespace

JuniorQueryResult JuniorControl::apply_query(const char* query, size_t length, Micros now_us) {
  JuniorQueryResult result{0, JuniorQueryError::None, 0, 0};
  for (int pass = 0; pass < 2; ++pass) {  // check every parameter, then apply them in order
    for (size_t start = 0, end = 0; start < length; start = end + 1) {
      end = start;
      while (end < length && query[end] != '&') ++end;
      if (end == start) continue;  // "&&" or a trailing '&'
      const Param p = param_at(query, start, end);
      if (pass == 0) {
        const JuniorQueryError error = check(p);
        if (error != JuniorQueryError::None) {
          return JuniorQueryResult{0, error, static_cast<uint16_t>(start), static_cast<uint16_t>(end - start)};
        }
        continue;
      }
      const int flag = flag_index(p);
      if (flag >= 0) {
        if (equals(p.value, p.value_len, proto::kJuniorFlagTrue)) motion_ = kFlagMotion[flag];
      } else {
        parse_unit_permille(p.value, p.value_len,
                            equals(p.name, p.name_len, proto::kJuniorParamLeftSpeed) ? &left_ : &right_);
      }
      ++result.applied;
    }
  }
  heard_ = true;
  last_request_us_ = now_us;
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
