// Benchmark firmware for the emulated ATmega328P: kMessages control messages "(1500,1500)", fed
// byte by byte to (1) the core's ControlParser, (2) a plain single-pass reference parser (no
// error results, no resynchronisation rules: the least a parser can do), (3) Car::feed, the
// whole receive path (parser + failsafe + reply queue). Each run is a function of its own (so the
// compiler treats each loop alike, whatever surrounds it), called between a rise and a fall of
// PB5, whose width in cycles the simavr harness measures: cycles per message = width /
// kMessages. Every loop branches on the parser's result, as a caller does. A fourth run feeds
// kSbusFrames SBUS frames (25 bytes each, 120 us apart as at 100 kbaud, frames 7 ms apart) to
// the core's SbusDecoder: cycles per frame = width / kSbusFrames. A fifth feeds kMacs signed
// messages "(1500,1500,COUNTER,MAC)" to Car::feed on a car with a key (roar/signing.h: parser,
// SipHash-2-4 MAC check, counter, failsafe): cycles per signed message = width / kMacs, beside
// the third run's unsigned ones. No Arduino core, no interrupts.
#include <avr/io.h>

#include "../sbus_feed.h"
#include "roar/car.h"
#include "roar/control_parser.h"
#include "roar/sbus.h"
#include "roar/signing.h"

namespace {
constexpr uint8_t kMessages = 60;  // (the chip has 2 KB of RAM: room for the stack of the signed run)
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
    car.feed(reinterpret_cast<const uint8_t*>(p), kMessageBytes, now);  // a message's bytes, as a board loop reads them
  }
}

constexpr uint8_t kMacs = 10;
constexpr uint8_t kSignedBytes = 33;  // the longest signed control message: 8 counter digits
// The signed messages reuse text (the first runs are over by then): the chip has 2 KB of RAM.
static_assert(kMacs * kSignedBytes < sizeof(text), "signed messages fit in text");
char* signed_message(uint8_t m) { return text + m * kSignedBytes; }

class RamNvm : public roar::Nvm {
 public:
  void read(uint16_t at, uint8_t* data, uint8_t n) override {
    for (uint8_t i = 0; i < n; ++i) data[i] = bytes_[at + i];
  }
  void write(uint16_t at, const uint8_t* data, uint8_t n) override {
    for (uint8_t i = 0; i < n; ++i) bytes_[at + i] = data[i];
  }

 private:
  uint8_t bytes_[roar::KeyRecord::kBytes] = {};
};
RamNvm nvm;
roar::Car& keyed_car = car;  // the third run's car, booted again with a key (RAM is short)

void put_hex(char* out, uint64_t v, uint8_t digits) {
  for (uint8_t i = 0; i < digits; ++i) out[digits - 1 - i] = "0123456789abcdef"[(v >> (4 * i)) & 0xF];
}

void sign_messages() {
  roar::KeyRecord record;
  record.keyed = true;
  for (uint8_t i = 0; i < roar::proto::kSignedKeyBytes; ++i) record.key[i] = i;
  record.store(nvm);
  keyed_car.boot(&nvm);  // session 1
  for (uint8_t m = 0; m < kMacs; ++m) {
    const uint32_t counter = 0x10000000ul + 1 + m;  // 8 digits: the longest
    char* t = signed_message(m);
    const char head[] = "(1500,1500,";
    for (uint8_t k = 0; k < sizeof(head) - 1; ++k) t[k] = head[k];
    put_hex(t + 11, counter, 8);
    t[19] = ',';
    put_hex(t + 20, roar::message_mac(record.key, 1, '(', 1500, 1500, counter), 12);
    t[32] = ')';
  }
}

__attribute__((noinline)) void run_signed() {
  roar::Micros now = 0;
  for (uint8_t m = 0; m < kMacs; ++m) {
    now += 2870;  // [us] 33 bytes at 115200 baud
    keyed_car.feed(reinterpret_cast<const uint8_t*>(signed_message(m)), kSignedBytes, now);
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
  sign_messages();
  timed(run_signed);
  // A sixth, empty pulse says the car took every signed message (its counter reached the last).
  if (keyed_car.auth().last_counter() == 0x10000000ul + kMacs) {
    timed([] {
      for (volatile uint8_t i = 0; i < 10; ++i) {
      }
    });
  }
  for (;;) {
  }
}
