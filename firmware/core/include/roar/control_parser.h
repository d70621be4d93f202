// Streaming parser for the control message "(THROTTLE,STEERING)". Fed one byte at a time;
// no buffer beyond an accumulator; resynchronises on the next '(' after any error. The state
// table is in protocol/PROTOCOL.md section 1.1; the golden vectors define its results.
//
// Built for speed on an 8-bit chip, where it runs for every received byte: the common byte, a
// digit inside a field, costs one test and a multiply-add. A field's state carries the number
// of digits it may still take (left_), which is non-zero only inside a field, so that test is
// "a digit, and room for it". feed() is always inlined, so that a caller's loop keeps the
// parser in registers (one copy per call site: the Car and the C ABI).
//
// Signed messages "(T,S,COUNTER,MAC)" and "[V,S,COUNTER,MAC]" (protocol/spec.toml [signed]) parse
// to the same results, with signature() saying what they carried; whether the MAC is right is
// the Authenticator's question (roar/signing.h), not the parser's. The two hex fields take the
// switch, not the decimal hot path (left_ stays 0 in them).
#pragma once
#include <stdint.h>

#include "roar/protocol.h"

namespace roar {

static_assert(proto::kSignedMacDigits == 12, "the MAC's digits are kept as 4 high and 8 low");

struct ControlCommand {
  uint16_t throttle_us;  // [us]
  uint16_t steering_us;  // [us]
};

inline ControlCommand neutral_command() {
  return ControlCommand{proto::kControlNeutralUs, proto::kControlNeutralUs};
}

// "[SPEED,STEERING]": a speed [mm/s] (a leading '-' drives backwards) and a steering pulse [us],
// for a board with a speed controller.
struct Setpoint {
  int16_t speed_mm_s;    // [mm/s] -kSetpointMaxSpeedMmS..kSetpointMaxSpeedMmS
  uint16_t steering_us;  // [us]
};

// What a signed message carried after its two fields (present false for an unsigned one; then
// counter and mac are not meaningful).
struct Signature {
  bool present;
  uint32_t counter;  // COUNTER
  uint64_t mac;      // MAC, the low kSignedMacBits bits
};

class ControlParser {
 public:
  // Consume one byte. On ParseResult::Ok, command() holds the new control message; on
  // ParseResult::Setpoint, setpoint() the new setpoint message.
  __attribute__((always_inline)) ParseResult feed(uint8_t byte);

  // The last valid control message (neutral until one has been parsed).
  const ControlCommand& command() const { return command_; }
  // The last valid setpoint message (stopped and centred until one has been parsed).
  const Setpoint& setpoint() const { return setpoint_; }
  // What the last valid message (control or setpoint) carried after its two fields.
  const Signature& signature() const { return signature_; }

  void reset() {
    state_ = State::Idle;
    left_ = 0;
  }

 private:
  // Fields: Throttle and Steering of "(T,S)", Speed and SetSteering of "[V,S]".
  // Counter and Mac are a signed message's hex fields. (feed() relies on this order: the four
  // decimal fields in a row.)
  enum class State : uint8_t { Idle, Garbage, Skip, Throttle, Steering, Speed, SetSteering, Counter, Mac };

  __attribute__((always_inline)) static bool is_line_end(uint8_t b) { return b == '\r' || b == '\n'; }
  __attribute__((always_inline)) static bool is_separator(uint8_t b) { return b == ' ' || is_line_end(b) || b == '\t' || b == '\0'; }
  __attribute__((always_inline)) static bool in_range(uint16_t v) {
    return static_cast<uint16_t>(v - proto::kControlMinUs) <= proto::kControlMaxUs - proto::kControlMinUs;
  }

  __attribute__((always_inline)) static bool is_start(uint8_t b) {
    return b == proto::kControlStartChar || b == proto::kSetpointStartChar;
  }
  ParseResult start_message(uint8_t start, ParseResult result) {
    state_ = start == proto::kControlStartChar ? State::Throttle : State::Speed;
    left_ = proto::kControlMaxDigits;
    value_ = 0;
    negative_ = false;
    return result;
  }
  __attribute__((always_inline)) ParseResult field_end(uint8_t byte);
  // Inlined too: an out-of-line member would take the parser's address, and the parser would
  // then live in memory instead of registers in its callers' loops (twice the cycles per byte).
  __attribute__((always_inline)) ParseResult hex_field(uint8_t byte);
  // The message ends: range checks, then the values become command() or setpoint().
  __attribute__((always_inline)) ParseResult finish(bool setpoint, uint16_t second, bool is_signed);

  State state_ = State::Idle;
  uint8_t left_ = 0;     // digits the current field may still take; 0 outside a field
  uint16_t value_ = 0;   // the current field's value so far
  uint16_t throttle_ = 0;  // the first field: a throttle, or a setpoint's speed magnitude
  bool negative_ = false;  // a setpoint's speed had a leading '-'
  bool setpoint_kind_ = false;  // in Counter or Mac: the message began with '['
  uint8_t hex_left_ = 0;   // hex digits the current hex field may still take
  uint16_t second_ = 0;    // a signed message's steering
  uint32_t counter_ = 0;   // COUNTER so far
  uint32_t mac_high_ = 0;  // MAC so far: its first 4 digits (16 bits),
  uint32_t mac_low_ = 0;   // and its last 8 (32-bit words: an 8-bit chip shifts 64-bit ones slowly)
  Signature signature_ = {false, 0, 0};
  ControlCommand command_ = {proto::kControlNeutralUs, proto::kControlNeutralUs};
  Setpoint setpoint_ = {0, proto::kControlNeutralUs};
};

inline ParseResult ControlParser::feed(uint8_t byte) {
  const uint8_t digit = static_cast<uint8_t>(byte - '0');
  if (digit <= 9 && left_ != 0) {  // the hot path: a digit inside a field with room for it
    --left_;
    value_ = static_cast<uint16_t>(value_ * 10u + digit);
    return ParseResult::None;
  }
  // Tests, not a switch: the states a message's bytes meet come first, and an 8-bit chip's jump
  // table would cost more than these compares.
  const State state = state_;
  if (static_cast<uint8_t>(static_cast<uint8_t>(state) - static_cast<uint8_t>(State::Throttle)) <= 3) {
    return field_end(byte);  // Throttle, Steering, Speed, SetSteering
  }
  if (state == State::Idle) {
    if (is_start(byte)) return start_message(byte, ParseResult::None);
    if (!is_separator(byte)) state_ = State::Garbage;
    return ParseResult::None;
  }
  if (state == State::Counter || state == State::Mac) return hex_field(byte);
  if (state == State::Garbage) {
    if (is_start(byte)) return start_message(byte, ParseResult::Garbage);
    if (!is_separator(byte)) return ParseResult::None;
    state_ = State::Idle;
    return ParseResult::Garbage;
  }
  // Skip
  if (is_start(byte)) return start_message(byte, ParseResult::None);
  if (byte == proto::kControlEndChar || byte == proto::kSetpointEndChar || is_line_end(byte)) state_ = State::Idle;
  return ParseResult::None;
}

// A byte in a field that is not a digit it has room for. The bytes that end a valid control
// message's fields (',' and ')') are tested first: they are the ones every message has.
inline ParseResult ControlParser::field_end(uint8_t byte) {
  const State state = state_;
  const bool has_digits = left_ != proto::kControlMaxDigits;
  if (byte == proto::kControlSeparatorChar) {
    if (has_digits && (state == State::Throttle || state == State::Speed)) {
      throttle_ = value_;
      state_ = state == State::Throttle ? State::Steering : State::SetSteering;
      left_ = proto::kControlMaxDigits;
      value_ = 0;
      return ParseResult::None;
    }
    if (has_digits) {  // after the steering: a signed message's COUNTER follows
      setpoint_kind_ = state == State::SetSteering;
      second_ = value_;
      state_ = State::Counter;
      left_ = 0;
      hex_left_ = proto::kSignedCounterDigits;
      counter_ = 0;
      return ParseResult::None;
    }
  } else if (byte == proto::kControlEndChar) {
    left_ = 0;
    state_ = State::Idle;
    if (state != State::Steering || !has_digits) return ParseResult::Syntax;
    return finish(false, value_, false);
  } else if (byte == proto::kSetpointEndChar) {
    left_ = 0;
    state_ = State::Idle;
    if (state != State::SetSteering || !has_digits) return ParseResult::Syntax;
    return finish(true, value_, false);
  } else if (static_cast<uint8_t>(byte - '0') <= 9) {  // a digit beyond kControlMaxDigits
    state_ = State::Skip;
    return ParseResult::TooLong;
  } else if (byte == '-' && state == State::Speed && !has_digits && !negative_) {
    negative_ = true;  // a setpoint's speed backwards
    return ParseResult::None;
  } else if (is_start(byte)) {
    return start_message(byte, ParseResult::Unterminated);
  } else if (is_line_end(byte)) {
    left_ = 0;
    state_ = State::Idle;
    return ParseResult::Unterminated;
  }
  left_ = 0;
  state_ = State::Skip;
  return ParseResult::Syntax;
}

// A byte inside a signed message's COUNTER or MAC (lowercase hex).
inline ParseResult ControlParser::hex_field(uint8_t byte) {
  const bool counter = state_ == State::Counter;
  uint8_t nibble = static_cast<uint8_t>(byte - '0');
  if (nibble > 9) nibble = static_cast<uint8_t>(byte - 'a') <= 5 ? static_cast<uint8_t>(byte - 'a' + 10) : 0xFF;
  if (nibble != 0xFF) {
    if (hex_left_ == 0) {
      state_ = State::Skip;
      return ParseResult::TooLong;
    }
    --hex_left_;
    if (counter) {
      counter_ = (counter_ << 4) | nibble;
    } else if (hex_left_ >= 8) {  // (hex_left_ already counts this digit out)
      mac_high_ = (mac_high_ << 4) | nibble;
    } else {
      mac_low_ = (mac_low_ << 4) | nibble;
    }
    return ParseResult::None;
  }
  const uint8_t end = setpoint_kind_ ? proto::kSetpointEndChar : proto::kControlEndChar;
  if (byte == proto::kControlSeparatorChar && counter && hex_left_ != proto::kSignedCounterDigits) {
    state_ = State::Mac;
    hex_left_ = proto::kSignedMacDigits;
    mac_high_ = mac_low_ = 0;
    return ParseResult::None;
  }
  if (byte == proto::kControlEndChar || byte == proto::kSetpointEndChar) {
    state_ = State::Idle;
    // no MAC, a truncated one, or the other kind's end
    if (counter || hex_left_ != 0 || byte != end) return ParseResult::Syntax;
    return finish(setpoint_kind_, second_, true);
  }
  if (is_start(byte)) return start_message(byte, ParseResult::Unterminated);
  if (is_line_end(byte)) {
    state_ = State::Idle;
    return ParseResult::Unterminated;
  }
  state_ = State::Skip;
  return ParseResult::Syntax;
}

inline ParseResult ControlParser::finish(bool setpoint, uint16_t second, bool is_signed) {
  if (setpoint) {
    if (throttle_ > proto::kSetpointMaxSpeedMmS || !in_range(second)) return ParseResult::Range;
    setpoint_ = Setpoint{static_cast<int16_t>(negative_ ? -static_cast<int16_t>(throttle_) : throttle_), second};
  } else {
    if (!in_range(throttle_) || !in_range(second)) return ParseResult::Range;
    command_ = ControlCommand{throttle_, second};
  }
  signature_.present = is_signed;  // (an unsigned message stores one byte: this runs for every message)
  if (is_signed) {
    signature_.counter = counter_;
    signature_.mac = static_cast<uint64_t>(mac_high_) << 32 | mac_low_;
  }
  return setpoint ? ParseResult::Setpoint : ParseResult::Ok;
}

}  // namespace roar
