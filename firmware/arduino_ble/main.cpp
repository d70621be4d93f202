// The car firmware for the Arduino Nano 33 BLE (BLE + USB serial) and the classic Nano
// (serial only): thin glue between the board's peripherals and roar::CarBoard.
//
//   USB serial 115200 / BLE writes -> CarBoard (parser, failsafe, RC override, brake FSM)
//   -> 50 Hz pulses on D5 (ESC) and D6 (steering); RC receiver on D3/D4 overrides the host.
#include <Arduino.h>

#include "ble_link.h"
#include "chip.h"
#include "roar/car_board.h"
#include "roar/protocol.h"

namespace {

class ArduinoHal : public roar::Hal {
 public:
  roar::RawMicros now_us() override { return micros(); }
  void write_pulses(uint16_t throttle_us, uint16_t steering_us) override { outputs::write(throttle_us, steering_us); }
  uint32_t frames_started() override { return outputs::frames_started(); }
  int read_byte() override { return Serial.read(); }
  size_t write_room() override {
#if defined(ARDUINO_ARCH_MBED)
    // The mbed core's USB serial cannot say how much room it has (availableForWrite() is 0);
    // its writes go through while a terminal holds the port open (DTR) and are dropped otherwise.
    return Serial.dtr() ? roar::proto::kSerialMaxReplyBytes : 0;
#else
    return static_cast<size_t>(Serial.availableForWrite());
#endif
  }
  void write(const char* text, size_t length) override { Serial.write(text, length); }
  void feed_watchdog() override { watchdog::feed(); }
  roar::Nvm* nvm() override { return storage::nvm(); }
};

ArduinoHal hal;
roar::CarBoard board(hal);

}  // namespace

void setup() {
  outputs::begin();
  Serial.begin(roar::proto::kSerialBaud);
  ble_link::begin();
  board.begin();
  watchdog::start();
}

void loop() {
  for (uint8_t ch = 0; ch < 2; ++ch) {
    const uint16_t width = outputs::take_rc_pulse(ch);
    if (width) board.rc_pulse(static_cast<roar::RcChannel>(ch), width);
  }
  ble_link::poll(board);
  const roar::CarOutputs out = board.poll();
  ble_link::publish(board, out);
#ifdef ROAR_TEST_HANG_ON_THROTTLE_US
  // Test builds only (the suite's emulator proves the watchdog): hang the loop for good once
  // the car outputs this throttle, as a firmware bug would.
  if (out.throttle_us == ROAR_TEST_HANG_ON_THROTTLE_US) {
    for (;;) {
    }
  }
#endif
}
