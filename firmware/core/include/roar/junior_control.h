// ROAR Junior (ESP32-CAM + L298N) HTTP control, board-independent: the query string of
// `GET /?forward=True&left_spd=0.5&right_spd=0.5` applied parameter by parameter, in order, as
// the original Junior firmware does, plus what it lacked: a query with any parameter that is
// not understood is refused whole (it changes nothing, and says why), and no request for
// kJuniorFailsafeTimeoutUs stops both sides. See PROTOCOL.md section 6.
#pragma once
#include <stddef.h>
#include <stdint.h>

#include "roar/clock.h"
#include "roar/l298n_driver.h"
#include "roar/protocol.h"

namespace roar {

enum class JuniorMotion : uint8_t { Stop, Forward, Backward, TurnLeft, TurnRight };

enum class JuniorQueryError : uint8_t {
  None = 0,
  UnknownName = 1,  // a parameter this robot does not have
  BadFlag = 2,      // a flag whose value is neither "True" nor "False"
  BadSpeed = 3,     // a speed that is not a decimal number 0..1
};

struct JuniorQueryResult {
  uint8_t applied;         // parameters applied (0 when refused)
  JuniorQueryError error;  // None, or why the query was refused
  uint16_t bad_at;         // offset in the query of the refused parameter
  uint16_t bad_length;     // its length ("name=value")
};

class JuniorControl {
 public:
  // Apply one query string (without the leading '?'), parameter by parameter, in order, and
  // restart the failsafe timeout; or, when any parameter is not understood, change nothing and
  // say which (an empty query is a valid request that changes nothing but the timeout).
  JuniorQueryResult apply_query(const char* query, size_t length, Micros now_us);

  // Signed per-side duties to drive now; both zero while stopped or after the failsafe timeout.
  SideDuties duties(Micros now_us) const;

  bool timed_out(Micros now_us) const;
  JuniorMotion motion() const { return motion_; }
  uint16_t left_permille() const { return left_; }
  uint16_t right_permille() const { return right_; }

 private:
  JuniorMotion motion_ = JuniorMotion::Stop;
  uint16_t left_ = proto::kL298nDutyFullScale;   // [permille] until the host sets a speed
  uint16_t right_ = proto::kL298nDutyFullScale;  // [permille]
  bool heard_ = false;
  Micros last_request_us_ = 0;
};

// Parses a speed "0", "1", "0.5", ".25", "1.0" (0..1, at most 3 decimals used) into permille.
// Returns false for anything else (negative, above 1, not a number).
bool parse_unit_permille(const char* text, size_t length, uint16_t* permille);

// Ultrasonic ranging: echo pulse width -> distance in whole centimetres (sound at 343 m/s, there
// and back). 0 means no echo.
constexpr uint32_t kSoundMmPerMs = 343;  // [mm/ms] = 343 m/s in air at 20 C
inline uint32_t echo_us_to_cm(uint32_t echo_us) { return echo_us * kSoundMmPerMs / 20000u; }

}  // namespace roar
