// Streaming parser for the control message "(THROTTLE,STEERING)". Fed one byte at a time;
// no buffer beyond an accumulator; resynchronises on the next '(' after any error. The state
// table is in protocol/PROTOCOL.md section 1.1; the golden vectors define its results.
//
// Built for speed on an 8-bit chip, where it runs for every received byte: the common byte, a
// digit inside a field, costs one test and a multiply-add. A field's state carries the number
// of digits it may still take (left_), which is non-zero only inside a field, so that test is
// "a digit, and room for it". feed() is always inlined, so that a caller's loop keeps the
// parser in registers (one copy per call site: the Car and the C ABI).
#pragma once
#include <stdint.h>

#include "roar/protocol.h"

namespace roar {

struct ControlCommand {
  uint16_t throttle_us;  // [us]
  uint16_t steering_us;  // [us]
};

inline ControlCommand neutral_command() {
  return ControlCommand{proto::kControlNeutralUs, proto::kControlNeutralUs};
}

class ControlParser {
 public:
  // Consume one byte. On ParseResult::Ok, command() holds the new message.
  __attribute__((always_inline)) ParseResult feed(uint8_t byte);

  // The last valid message (neutral until one has been parsed).
  const ControlCommand& command() const { return command_; }

  void reset() {
    state_ = State::Idle;
    left_ = 0;
  }

 private:
  enum class State : uint8_t { Idle, Garbage, Skip, Throttle, Steering };

  __attribute__((always_inline)) static bool is_line_end(uint8_t b) { return b == '\r' || b == '\n'; }
  __attribute__((always_inline)) static bool is_separator(uint8_t b) { return b == ' ' || is_line_end(b) || b == '\t' || b == '\0'; }
  __attribute__((always_inline)) static bool in_range(uint16_t v) {
    return static_cast<uint16_t>(v - proto::kControlMinUs) <= proto::kControlMaxUs - proto::kControlMinUs;
  }

  ParseResult start_message(ParseResult result) {
    state_ = State::Throttle;
    left_ = proto::kControlMaxDigits;
    value_ = 0;
    return result;
  }
  __attribute__((always_inline)) ParseResult field_end(uint8_t byte);

  State state_ = State::Idle;
  uint8_t left_ = 0;     // digits the current field may still take; 0 outside a field
  uint16_t value_ = 0;   // the current field's value so far
  uint16_t throttle_ = 0;
  ControlCommand command_ = {proto::kControlNeutralUs, proto::kControlNeutralUs};
};

inline ParseResult ControlParser::feed(uint8_t byte) {
  const uint8_t digit = static_cast<uint8_t>(byte - '0');
  if (digit <= 9 && left_ != 0) {  // the hot path: a digit inside a field with room for it
    --left_;
    value_ = static_cast<uint16_t>(value_ * 10u + digit);
    return ParseResult::None;
  }
  switch (state_) {
    case State::Throttle:
    case State::Steering:
      return field_end(byte);
    case State::Idle:
      if (byte == proto::kControlStartChar) return start_message(ParseResult::None);
      if (!is_separator(byte)) state_ = State::Garbage;
      return ParseResult::None;
    case State::Garbage:
      if (byte == proto::kControlStartChar) return start_message(ParseResult::Garbage);
      if (!is_separator(byte)) return ParseResult::None;
      state_ = State::Idle;
      return ParseResult::Garbage;
    case State::Skip:
      if (byte == proto::kControlStartChar) return start_message(ParseResult::None);
      if (byte == proto::kControlEndChar || is_line_end(byte)) state_ = State::Idle;
      return ParseResult::None;
  }
  return ParseResult::None;
}

// A byte in a field that is not a digit it has room for.
inline ParseResult ControlParser::field_end(uint8_t byte) {
  const bool has_digits = left_ != proto::kControlMaxDigits;
  if (static_cast<uint8_t>(byte - '0') <= 9) {  // a digit beyond kControlMaxDigits
    state_ = State::Skip;
    return ParseResult::TooLong;
  }
  if (byte == proto::kControlSeparatorChar && state_ == State::Throttle && has_digits) {
    throttle_ = value_;
    state_ = State::Steering;
    left_ = proto::kControlMaxDigits;
    value_ = 0;
    return ParseResult::None;
  }
  left_ = 0;
  if (byte == proto::kControlEndChar) {
    const bool complete = state_ == State::Steering && has_digits;
    state_ = State::Idle;
    if (!complete) return ParseResult::Syntax;
    if (!in_range(throttle_) || !in_range(value_)) return ParseResult::Range;
    command_ = ControlCommand{throttle_, value_};
    return ParseResult::Ok;
  }
  if (byte == proto::kControlStartChar) return start_message(ParseResult::Unterminated);
  if (is_line_end(byte)) {
    state_ = State::Idle;
    return ParseResult::Unterminated;
  }
  state_ = State::Skip;
  return ParseResult::Syntax;
}

}  // namespace roar
