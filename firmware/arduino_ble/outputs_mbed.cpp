// Nano 33 BLE (nRF52840, Arduino mbed core): servo frames from the Arduino Servo library (a
// hardware timer per frame), RC pulses timed with attachInterrupt on both edges. frames_started()
// counts elapsed 20 ms periods since begin(): the Servo library emits one frame per period.
#if defined(ARDUINO_ARCH_MBED)
#include <Arduino.h>
#include <Servo.h>

#include "outputs.h"
#include "pins.h"
#include "roar/protocol.h"

namespace {
Servo esc, steering;
uint32_t started_us = 0;
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
  esc.attach(pins::kThrottleOut, roar::proto::kControlMinUs, roar::proto::kControlMaxUs);
  steering.attach(pins::kSteeringOut, roar::proto::kControlMinUs, roar::proto::kControlMaxUs);
  write(roar::proto::kControlNeutralUs, roar::proto::kControlNeutralUs);
  started_us = micros();
  pinMode(pins::kRcThrottleIn, INPUT);
  pinMode(pins::kRcSteeringIn, INPUT);
  attachInterrupt(digitalPinToInterrupt(pins::kRcThrottleIn), on_rc_throttle, CHANGE);
  attachInterrupt(digitalPinToInterrupt(pins::kRcSteeringIn), on_rc_steering, CHANGE);
}

void write(uint16_t throttle_us, uint16_t steering_us) {
  esc.writeMicroseconds(throttle_us);
  steering.writeMicroseconds(steering_us);
}

uint32_t frames_started() { return (micros() - started_us) / roar::proto::kTimingServoFrameUs + 1; }

uint16_t take_rc_pulse(uint8_t channel) {
  noInterrupts();
  const uint16_t w = rc_width_us[channel];
  rc_width_us[channel] = 0;
  interrupts();
  return w;
}

}  // namespace outputs
#endif
