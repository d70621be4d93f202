// Benchmark firmware for the emulated ATmega328P: parse kMessages control messages with the
// core's ControlParser, then push the same bytes through Car::feed (parser + watchdog + reply
// queue). Each run is bracketed by a high pulse on PB5, whose width in cycles the simavr harness
// measures: cycles per message = width / kMessages. No Arduino core, no interrupts.
#include <avr/io.h>

#include "roar/car.h"
#include "roar/control_parser.h"

namespace {
constexpr uint8_t kMessages = 100;
char text[kMessages * 11 + 1];

void make_messages() {  // "(1000,2000)" .. with varying digits, 11 bytes each
  for (uint8_t i = 0; i < kMessages; ++i) {
    const uint16_t t = 1000 + i * 9, s = 2000 - i * 7;
    char* m = text + i * 11;
    m[0] = '(';
    m[5] = ',';
    m[10] = ')';
    for (uint8_t d = 0; d < 4; ++d) {
      static const uint16_t kPow[4] = {1000, 100, 10, 1};
      m[1 + d] = static_cast<char>('0' + (t / kPow[d]) % 10);
      m[6 + d] = static_cast<char>('0' + (s / kPow[d]) % 10);
    }
  }
}
}  // namespace

int main() {
  make_messages();
  DDRB |= _BV(PB5);
  roar::ControlParser parser;
  roar::Car car;
  volatile uint8_t ok = 0;

  PORTB |= _BV(PB5);  // run 1: the parser alone
  for (const char* p = text; *p; ++p) ok += parser.feed(static_cast<uint8_t>(*p)) == roar::ParseResult::Ok;
  PORTB &= ~_BV(PB5);

  car.feed('(', 0);  // a neutral first, so run 2 measures armed, accepted commands
  for (const char* p = "1500,1500)"; *p; ++p) car.feed(static_cast<uint8_t>(*p), 0);
  PORTB |= _BV(PB5);  // run 2: the car's whole receive path
  uint32_t now = 1000;
  for (const char* p = text; *p; ++p) car.feed(static_cast<uint8_t>(*p), now += 87);  // 87 us per byte at 115200 baud
  PORTB &= ~_BV(PB5);

  for (;;) {
  }
}
