// The board logic of a servo/ESC car, the same on every board and in the simulator:
//
//   bytes -> ControlParser -> Authenticator -> CommandWatchdog -> RcOverride -> BrakeFsm -> map_pulse -> pulses
//
// With a key (roar/signing.h, set over serial only) the car acts only on signed messages; the
// failsafe counts only messages that passed.
//
// Board glue calls feed() for every received byte, rc_pulse() for every measured receiver
// pulse, step() every loop (>= 1 kHz is ideal) and writes the returned pulses to the outputs,
// and drains take_reply() into its serial port when there is room.
#pragma once
#include <stddef.h>
#include <stdint.h>

#include "roar/brake_fsm.h"
#include "roar/clock.h"
#include "roar/control_parser.h"
#include "roar/failsafe.h"
#include "roar/rc_override.h"
#include "roar/servo_output.h"
#include "roar/signing.h"

namespace roar {

struct CarConfig {
  DurationUs failsafe_timeout_us = proto::kTimingFailsafeTimeoutUs;  // [us]
  BrakeConfig brake;
  ChannelCalibration throttle;
  ChannelCalibration steering;
  bool failsafe_enabled = true;     // off only for bench experiments; boots armed when off
  bool brake_fsm_enabled = true;    // off only to show what the ESC does without it
  bool rc_override_enabled = true;
};

enum class ControlSource : uint8_t {
  Failsafe = 0,  // latched: neutral and centre
  Host = 1,      // the latest accepted host command
  Rc = 2,        // the RC receiver
};

struct CarOutputs {
  uint16_t throttle_us;  // [us] to the ESC
  uint16_t steering_us;  // [us] to the steering servo
  ControlSource source;
  BrakePhase brake_phase;
};

enum class Reply : uint8_t { Ready, Error, Failsafe, Armed, Unsupported, Session, Key };

// Where a byte came from: only the serial link (USB) may set or clear the key.
enum class Link : uint8_t { Serial, Radio };

class Car {
 public:
  explicit Car(const CarConfig& config = CarConfig());

  // Queue the boot banner. Call once when the serial port is up. nvm: where the key and the
  // session counter live (nullptr: the board has none, so it can never have a key).
  void boot(Nvm* nvm = nullptr);

  // Received bytes (serial, or a BLE write), in order: one call per chunk keeps the parser in
  // registers across its bytes (a call per byte costs an 8-bit chip more than the parsing).
  void feed(const uint8_t* data, size_t n, Micros now_us, Link link = Link::Serial);
  void feed(uint8_t byte, Micros now_us, Link link = Link::Serial) { feed(&byte, 1, now_us, link); }

  // One measured RC receiver pulse.
  void rc_pulse(RcChannel channel, uint16_t width_us, Micros now_us) { rc_.on_pulse(channel, width_us, now_us); }

  // The pulses to output now. `frames_started`: see BrakeFsm::step.
  CarOutputs step(Micros now_us, uint32_t frames_started);

  // Pops the next reply line (NUL-terminated, ends with '\n') into buf. Returns its length
  // without the NUL, or 0 when none is pending or cap is too small (the line stays queued).
  size_t take_reply(char* buf, size_t cap);

  // Replies dropped because the queue was full (the host is not reading).
  uint32_t replies_dropped() const { return replies_dropped_; }
  const ControlParser& parser() const { return parser_; }
  const Authenticator& auth() const { return keys_.auth(); }
  bool latched() const { return config_.failsafe_enabled && watchdog_.latched(); }

 private:
  static const uint8_t kQueue = 8;  // pending reply lines
  struct QueuedReply {
    Reply kind;
    ParseResult detail;
    uint32_t value;  // after ERR unsigned / forged: the session; after ERR replay: the last counter
  };
  void queue(Reply kind, ParseResult detail = ParseResult::None, uint32_t value = 0);
  void on_watchdog(WatchdogEvent ev);
  void on_key_line(KeyLine::Event ev);
  void on_message(ParseResult r, Micros now_us);

  CarConfig config_;
  ControlParser parser_;
  KeyStore keys_;
  KeyLine key_line_;
  CommandWatchdog watchdog_;
  RcOverride rc_;
  BrakeFsm brake_;
  ControlCommand host_command_;
  bool latch_notified_ = false;  // FAILSAFE already printed for this latched period
  QueuedReply replies_[kQueue];
  uint8_t reply_head_ = 0;
  uint8_t reply_count_ = 0;
  uint32_t replies_dropped_ = 0;
};

}  // namespace roar
