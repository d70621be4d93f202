#include "roar/control_parser.h"

namespace roar {
namespace {

bool is_line_end(uint8_t b) { return b == '\r' || b == '\n'; }
bool is_separator(uint8_t b) { return is_line_end(b) || b == ' ' || b == '\t' || b == '\0'; }
bool is_digit(uint8_t b) { return b >= '0' && b <= '9'; }
bool in_range(uint16_t v) { return v >= proto::kControlMinUs && v <= proto::kControlMaxUs; }

}  // namespace

void ControlParser::reset() {
  state_ = State::Idle;
  digits_ = 0;
}

ParseResult ControlParser::start_message(ParseResult result) {
  state_ = State::Throttle;
  digits_ = 0;
  fields_[0] = fields_[1] = 0;
  return result;
}

ParseResult ControlParser::feed(uint8_t byte) {
  switch (state_) {
    case State::Idle:
      if (byte == proto::kControlStartChar) return start_message(ParseResult::None);
      if (!is_separator(byte)) state_ = State::Garbage;
      return ParseResult::None;
    case State::Garbage:
      if (byte == proto::kControlStartChar) return start_message(ParseResult::Garbage);
      if (is_separator(byte)) {
        state_ = State::Idle;
        return ParseResult::Garbage;
      }
      return ParseResult::None;
    case State::Skip:
      if (byte == proto::kControlStartChar) return start_message(ParseResult::None);
      if (byte == proto::kControlEndChar || is_line_end(byte)) state_ = State::Idle;
      return ParseResult::None;
    case State::Throttle:
    case State::Steering:
      return field_byte(byte);
  }
  return ParseResult::None;
}

ParseResult ControlParser::field_byte(uint8_t byte) {
  const uint8_t field = state_ == State::Throttle ? 0 : 1;
  if (is_digit(byte)) {
    if (digits_ == proto::kControlMaxDigits) {
      state_ = State::Skip;
      return ParseResult::TooLong;
    }
    ++digits_;
    fields_[field] = static_cast<uint16_t>(fields_[field] * 10u + (byte - '0'));
    return ParseResult::None;
  }
  if (byte == proto::kControlSeparatorChar && field == 0 && digits_ > 0) {
    state_ = State::Steering;
    digits_ = 0;
    return ParseResult::None;
  }
  if (byte == proto::kControlEndChar) {
    state_ = State::Idle;
    if (field == 0 || digits_ == 0) return ParseResult::Syntax;
    if (!in_range(fields_[0]) || !in_range(fields_[1])) return ParseResult::Range;
    command_ = ControlCommand{fields_[0], fields_[1]};
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
