// ControlParser is defined inline in its header (it runs for every received byte); this unit
// keeps one out-of-line copy of feed() for callers that take its address.
#include "roar/control_parser.h"

namespace roar {

// A byte inside a signed message's COUNTER or MAC (lowercase hex).
ParseResult ControlParser::hex_field(uint8_t byte) {
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
    } else {
      mac_ = (mac_ << 4) | nibble;
    }
    return ParseResult::None;
  }
  const uint8_t end = setpoint_kind_ ? proto::kSetpointEndChar : proto::kControlEndChar;
  if (byte == proto::kControlSeparatorChar && counter && hex_left_ != proto::kSignedCounterDigits) {
    state_ = State::Mac;
    hex_left_ = proto::kSignedMacDigits;
    mac_ = 0;
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

}  // namespace roar
