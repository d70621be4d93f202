// Benchmark firmware for the emulated ATmega328P: kMessages control messages "(1500,1500)", fed
// byte by byte to (1) the core's ControlParser, (2) a plain single-pass reference parser (no
// error results, no resynchronisation rules: the least a parser can do), (3) Car::feed, the
// whole receive path (parser + failsafe + reply queue). Each run is a function of its own (so the
// compiler treats each loop alike, whatever surrounds it), called between a rise and a fall of
// PB5, whose width in cycles the simavr harness measures: cycles per message = width /
// kMessages. Every loop branches on the parser's result, as a caller does. A fourth run feeds
// kSbusFrames SBUS frames (25 bytes each, 120 us apart as at 100 kbaud, frames 7 ms apart) to
// the core's SbusDecoder: cycles per frame = width / kSbusFrames. A fifth computes kMacs SipHash-2-4
// MACs (roar/siphash.h, the signed mode's MAC) of kMacBytes each, byte by byte as a parser
// would: cycles per MAC = width / kMacs. No Arduino core, no interrupts.
#include <avr/io.h>

#include "../sbus_feed.h"
#include "roar/car.h"
#include "roar/control_parser.h"
#include "roar/sbus.h"
#include "roar/siphash.h"

namespace {
constexpr uint8_t kMessages = 100;
constexpr char kMessage[] = "(1500,1500)";
constexpr uint8_t kMessageBytes = sizeof(kMessage) - 1;
char text[kMessages * kMessageBytes + 1];

// The reference: '(' digits ',' digits ')' with the range check, anything else starts over.
class PlainParser {
 public:
  bool feed(uint8_t c) {
    switch (state_) {
      case 0:
        if (c == '(') {
          a_ = b_ = 0;
          state_ = 1;
        }
        return false;
      case 1:
        if (c >= '0' && c <= '9') {
          a_ = static_cast<uint16_t>(a_ * 10u + (c - '0'));
          return false;
        }
        state_ = c == ',' ? 2 : 0;
        return false;
      default:
        if (c >= '0' && c <= '9') {
          b_ = static_cast<uint16_t>(b_ * 10u + (c - '0'));
          return false;
        }
        state_ = 0;
        return c == ')' && a_ >= 1000 && a_ <= 2000 && b_ >= 1000 && b_ <= 2000;
    }
  }

 private:
  uint8_t state_ = 0;
  uint16_t a_ = 0, b_ = 0;
};

__attribute__((noinline)) uint8_t run_core_parser() {
  roar::ControlParser parser;
  uint8_t ok = 0;
  for (const char* p = text; *p; ++p) {
    if (parser.feed(static_cast<uint8_t>(*p)) == roar::ParseResult::Ok) ++ok;
  }
  return ok;
}

__attribute__((noinline)) uint8_t run_plain_parser() {
  PlainParser parser;
  uint8_t ok = 0;
  for (const char* p = text; *p; ++p) {
    if (parser.feed(static_cast<uint8_t>(*p))) ++ok;
  }
  return ok;
}

roar::Car car;

constexpr uint8_t kSbusFrames = 10;
uint8_t sbus_bytes[kSbusFrames][roar::proto::kSbusFrameBytes];
roar::SbusDecoder sbus;

__attribute__((noinline)) void run_car() {  // one clock reading per message, as a board loop takes it
  roar::Micros now = 1000;
  for (const char* p = text; *p; p += kMessageBytes) {
    now += 957;  // [us] 11 bytes at 115200 baud
    for (uint8_t k = 0; k < kMessageBytes; ++k) car.feed(static_cast<uint8_t>(p[k]), now);
  }
}

constexpr uint8_t kMacs = 10;
constexpr uint8_t kMacBytes = 24;  // a control message with its counter: the bytes a MAC covers
volatile uint64_t mac_out;

__attribute__((noinline)) void run_siphash() {
  static const uint8_t key[roar::kSipKeyBytes] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
  for (uint8_t i = 0; i < kMacs; ++i) {
    roar::SipHash24 h;
    h.begin(key);
    for (uint8_t k = 0; k < kMacBytes; ++k) h.add(static_cast<uint8_t>(text[i * kMacBytes + k]));
    mac_out = h.finish();
  }
}

template <typename Run>
void timed(Run run) {
  PORTB |= _BV(PB5);
  run();
  PORTB &= ~_BV(PB5);
}
}  // namespace

volatile uint8_t accepted[3];

int main() {
  for (uint8_t i = 0; i < kMessages; ++i) {
    for (uint8_t k = 0; k < kMessageBytes; ++k) text[i * kMessageBytes + k] = kMessage[k];
  }
  DDRB |= _BV(PB5);
  timed([] { accepted[0] = run_core_parser(); });
  timed([] { accepted[1] = run_plain_parser(); });
  car.feed('(', 0);  // a neutral first, so run 3 measures armed, accepted commands
  for (const char* p = "1500,1500)"; *p; ++p) car.feed(static_cast<uint8_t>(*p), 0);
  timed(run_car);
  roar::SbusFrame frame = {};
  for (uint8_t f = 0; f < kSbusFrames; ++f) {
    for (uint8_t c = 0; c < roar::kSbusChannels; ++c) frame.raw[c] = static_cast<uint16_t>(200 + 97 * (f + c));
    roar::sbus_encode(frame, sbus_bytes[f]);
  }
  timed([] { accepted[2] = feed_sbus_frames<uint8_t>(sbus, sbus_bytes); });
  timed(run_siphash);
  for (;;) {
  }
}
