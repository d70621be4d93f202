// ATmega328P (classic Nano): servo frames from Timer1 in CTC mode at 0.5 us per tick. Each frame
// raises D5 for the throttle width, then D6 for the steering width, then idles to 20 ms; the
// ISR counts each frame as it starts. D5 and D6 are Timer0 pins, so the edges come from this
// ISR (other interrupts can delay an edge by a few microseconds, as on any Arduino servo
// output). RC pulses on D3/D4 are timed with micros() from the pin-change interrupt of port D.
// The chip's watchdog (WDT) resets it when the loop stops feeding it.
#if defined(ARDUINO_ARCH_AVR)
#include <Arduino.h>
#include <avr/eeprom.h>
#include <avr/wdt.h>
#include <util/atomic.h>

#include "chip.h"
#include "pins.h"
#include "roar/protocol.h"

namespace {
constexpr uint16_t kFrameUs = roar::proto::kTimingServoFrameUs;  // [us]
constexpr uint16_t kTicksPerUs = 2;                              // Timer1 at F_CPU / 8
constexpr uint8_t kThrottleBit = _BV(pins::kThrottleOut);        // PORTD bit of D5
constexpr uint8_t kSteeringBit = _BV(pins::kSteeringOut);        // PORTD bit of D6
constexpr uint8_t kRcBits[2] = {_BV(pins::kRcThrottleIn), _BV(pins::kRcSteeringIn)};

volatile uint16_t pending_throttle = roar::proto::kControlNeutralUs, pending_steering = roar::proto::kControlNeutralUs;
uint16_t frame_throttle = roar::proto::kControlNeutralUs, frame_steering = roar::proto::kControlNeutralUs;
volatile uint32_t frames = 0;
uint8_t phase = 0;

volatile uint8_t rc_last_pind = 0;
volatile uint32_t rc_rise_us[2] = {0, 0};
volatile uint16_t rc_width_us[2] = {0, 0};
}  // namespace

ISR(TIMER1_COMPA_vect) {
  // CTC: the counter restarted at this match; OCR1A now sets the length of the next phase.
  switch (phase) {
    case 0:
      PORTD |= kThrottleBit;  // first, so both edges of a pulse see the same ISR entry latency
      frame_throttle = pending_throttle;  // a new value takes effect at a frame start only
      frame_steering = pending_steering;
      ++frames;
      OCR1A = frame_throttle * kTicksPerUs - 1;
      phase = 1;
      break;
    case 1:
      PORTD = (PORTD & ~kThrottleBit) | kSteeringBit;
      OCR1A = frame_steering * kTicksPerUs - 1;
      phase = 2;
      break;
    default:
      PORTD &= ~kSteeringBit;
      OCR1A = (kFrameUs - frame_throttle - frame_steering) * kTicksPerUs - 1;
      phase = 0;
      break;
  }
}

ISR(PCINT2_vect) {
  const uint8_t now_pind = PIND;
  const uint8_t changed = now_pind ^ rc_last_pind;
  rc_last_pind = now_pind;
  const uint32_t now = micros();
  for (uint8_t ch = 0; ch < 2; ++ch) {
    if (!(changed & kRcBits[ch])) continue;
    if (now_pind & kRcBits[ch]) {
      rc_rise_us[ch] = now;
    } else {
      const uint32_t width = now - rc_rise_us[ch];
      rc_width_us[ch] = width > 0xFFFF ? 0xFFFF : static_cast<uint16_t>(width);
    }
  }
}

namespace outputs {

void begin() {
  DDRD |= kThrottleBit | kSteeringBit;
  PORTD &= ~(kThrottleBit | kSteeringBit);
  TCCR1A = 0;
  TCCR1B = _BV(WGM12) | _BV(CS11);  // CTC, TOP = OCR1A, clk/8
  TCNT1 = 0;
  OCR1A = 100;
  TIFR1 = _BV(OCF1A);
  TIMSK1 = _BV(OCIE1A);

  pinMode(pins::kRcThrottleIn, INPUT);
  pinMode(pins::kRcSteeringIn, INPUT);
  rc_last_pind = PIND;
  PCMSK2 |= kRcBits[0] | kRcBits[1];  // D3 = PCINT19, D4 = PCINT20
  PCIFR = _BV(PCIF2);
  PCICR |= _BV(PCIE2);
}

void write(uint16_t throttle_us, uint16_t steering_us) {
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    pending_throttle = throttle_us;
    pending_steering = steering_us;
  }
}

uint32_t frames_started() {
  uint32_t n;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { n = frames; }
  return n;
}

uint16_t take_rc_pulse(uint8_t channel) {
  uint16_t w;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    w = rc_width_us[channel];
    rc_width_us[channel] = 0;
  }
  return w;
}

}  // namespace outputs
// After a watchdog reset the WDT stays on at its shortest period (15 ms): switch it off before
// the C runtime and setup() run, or the board would reset forever. .init3 runs before
// constructors and main().
extern "C" void roar_watchdog_off_at_reset() __attribute__((naked, used, section(".init3")));
void roar_watchdog_off_at_reset() {
  MCUSR = 0;
  wdt_disable();
}

namespace storage {
namespace {
class Eeprom : public roar::Nvm {
 public:
  void read(uint16_t at, uint8_t* data, uint8_t n) override {
    eeprom_read_block(data, reinterpret_cast<const void*>(at), n);
  }
  // Only the bytes that change are written (3.4 ms each): a boot's new session is a few bytes.
  void write(uint16_t at, const uint8_t* data, uint8_t n) override {
    eeprom_update_block(data, reinterpret_cast<void*>(at), n);
  }
};
Eeprom eeprom;
}  // namespace
roar::Nvm* nvm() { return &eeprom; }
}  // namespace storage

namespace watchdog {
static_assert(roar::proto::kTimingLoopWatchdogUs == 250000ul, "WDTO_250MS below must match the spec");
void start() { wdt_enable(WDTO_250MS); }
void feed() { wdt_reset(); }
}  // namespace watchdog
#endif
