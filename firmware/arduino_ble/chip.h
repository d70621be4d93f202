// What differs between the two chips of this board folder, one implementation each:
// chip_avr.cpp (classic Nano, ATmega328P: Timer1 and pin-change interrupts, no libraries) and
// chip_mbed.cpp (Nano 33 BLE, nRF52840: mbed timers, attachInterrupt, mbed::Watchdog).
//   - 50 Hz pulse outputs for the ESC (D5) and the steering servo (D6), with a count of the
//     frames really started (the brake sequence relies on it);
//   - RC receiver pulse capture on D3/D4;
//   - the hardware watchdog;
//   - non-volatile memory for the signing key and session (roar/signing.h).
#pragma once
#include <stdint.h>

#include "roar/signing.h"

namespace outputs {
void begin();                                     // start frames at neutral, start RC capture
void write(uint16_t throttle_us, uint16_t steering_us);  // taken at the next frame start
uint32_t frames_started();                        // frames begun since begin(), counted as they start (wraps)
// The latest complete RC pulse on channel 0 (throttle) or 1 (steering) since the last call, in
// microseconds, or 0 when none arrived.
uint16_t take_rc_pulse(uint8_t channel);
}  // namespace outputs

namespace watchdog {
void start();  // reset the chip if feed() is not called for timing.loop_watchdog_us
void feed();
}  // namespace watchdog

namespace storage {
// The chip's non-volatile memory for the core: EEPROM on the ATmega328P, the last flash sector on
// the nRF52840; nullptr when it cannot be used (that car can then never be given a key).
roar::Nvm* nvm();
}  // namespace storage
