// Streaming parser for the control message "(THROTTLE,STEERING)". Fed one byte at a time;
// no buffer beyond two accumulators; resynchronises on the next '(' after any error.
// The state table is in protocol/PROTOCOL.md section 1.1.
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
  ParseResult feed(uint8_t byte);

  // The last valid message (neutral until one has been parsed).
  const ControlCommand& command() const { return command_; }

  void reset();

 private:
  enum class State : uint8_t { Idle, Garbage, Throttle, Steering, Skip };

  ParseResult start_message(ParseResult result);
  ParseResult field_byte(uint8_t byte);

  State state_ = State::Idle;
  uint8_t digits_ = 0;        // digits in the current field
  uint16_t fields_[2] = {0, 0};
  ControlCommand command_ = {proto::kControlNeutralUs, proto::kControlNeutralUs};
};

}  // namespace roar
