// Nano 33 BLE (nRF52840, Arduino mbed core): servo frames from mbed timers. A ticker starts a
// frame every 20 ms: it counts the frame, takes the pending widths, arms one timeout per output
// for the falling edge and raises both outputs (edges come from timer interrupts, like the
// Servo library's, so a pulse may run a few microseconds long). RC pulses are timed with
// attachInterrupt on both edges. The nRF52 watchdog (mbed::Watchdog) resets the chip when the
// loop stops feeding it. The signing key and session live in the last flash sector (mbed's
// FlashIAP), read once at boot and rewritten whole when they change (a boot's session, a key).
#if defined(ARDUINO_ARCH_MBED)
#include <Arduino.h>
#include <FlashIAP.h>
#include <mbed.h>

#include <chrono>

#include "chip.h"
#include "pins.h"
#include "roar/protocol.h"

namespace {
using std::chrono::microseconds;

mbed::Ticker frame_start;
mbed::Timeout throttle_end, steering_end;
volatile uint16_t pending_us[2] = {roar::proto::kControlNeutralUs, roar::proto::kControlNeutralUs};
volatile uint32_t frames = 0;

void lower_throttle() { digitalWrite(pins::kThrottleOut, LOW); }
void lower_steering() { digitalWrite(pins::kSteeringOut, LOW); }

void start_frame() {  // timer interrupt context
  ++frames;
  throttle_end.attach(lower_throttle, microseconds(pending_us[0]));
  steering_end.attach(lower_steering, microseconds(pending_us[1]));
  digitalWrite(pins::kThrottleOut, HIGH);
  digitalWrite(pins::kSteeringOut, HIGH);
}

volatile uint32_t rc_rise_us[2] = {0, 0};
volatile uint16_t rc_width_us[2] = {0, 0};
constexpr uint8_t kRcPins[2] = {pins::kRcThrottleIn, pins::kRcSteeringIn};

void on_rc_edge(uint8_t ch) {
  const uint32_t now = micros();
  if (digitalRead(kRcPins[ch])) {
    rc_rise_us[ch] = now;
  } else {
    const uint32_t width = now - rc_rise_us[ch];
    rc_width_us[ch] = width > 0xFFFF ? 0xFFFF : static_cast<uint16_t>(width);
  }
}
void on_rc_throttle() { on_rc_edge(0); }
void on_rc_steering() { on_rc_edge(1); }
}  // namespace

namespace outputs {

void begin() {
  pinMode(pins::kThrottleOut, OUTPUT);
  pinMode(pins::kSteeringOut, OUTPUT);
  digitalWrite(pins::kThrottleOut, LOW);
  digitalWrite(pins::kSteeringOut, LOW);
  frame_start.attach(start_frame, microseconds(roar::proto::kTimingServoFrameUs));
  pinMode(pins::kRcThrottleIn, INPUT);
  pinMode(pins::kRcSteeringIn, INPUT);
  attachInterrupt(digitalPinToInterrupt(pins::kRcThrottleIn), on_rc_throttle, CHANGE);
  attachInterrupt(digitalPinToInterrupt(pins::kRcSteeringIn), on_rc_steering, CHANGE);
}

void write(uint16_t throttle_us, uint16_t steering_us) {
  noInterrupts();  // a frame takes both widths of one write
  pending_us[0] = throttle_us;
  pending_us[1] = steering_us;
  interrupts();
}

uint32_t frames_started() { return frames; }  // one aligned word: a single load

uint16_t take_rc_pulse(uint8_t channel) {
  noInterrupts();
  const uint16_t w = rc_width_us[channel];
  rc_width_us[channel] = 0;
  interrupts();
  return w;
}

}  // namespace outputs

namespace storage {
namespace {
// The last flash sector (mbed FlashIAP), erased and programmed whole on a write (~90 ms, within
// the loop watchdog: at boot and on a KEY line only).
class FlashSector : public roar::CachedNvm {
 public:
  bool begin() {
    if (flash_.init() != 0) return false;
    const uint32_t end = flash_.get_flash_start() + flash_.get_flash_size();
    address_ = end - flash_.get_sector_size(end - 1);
    return flash_.read(cache(), address_, kBytes) == 0;  // erased flash reads 0xFF: no key
  }

 private:
  void persist(const uint8_t* data, uint8_t n) override {
    flash_.erase(address_, flash_.get_sector_size(address_));
    flash_.program(data, address_, n);
  }
  mbed::FlashIAP flash_;
  uint32_t address_ = 0;
};
FlashSector sector;
}  // namespace

roar::Nvm* nvm() {
  static const bool usable = sector.begin();
  return usable ? &sector : nullptr;
}
}  // namespace storage

namespace watchdog {
void start() { mbed::Watchdog::get_instance().start(roar::proto::kTimingLoopWatchdogUs / 1000); }  // [ms]
void feed() { mbed::Watchdog::get_instance().kick(); }
}  // namespace watchdog
#endif
