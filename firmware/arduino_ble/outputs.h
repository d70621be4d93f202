// 50 Hz pulse outputs for the ESC (D5) and the steering servo (D6), and RC receiver pulse
// capture on D3/D4. One implementation per architecture: outputs_avr.cpp (Timer1 and pin-change
// interrupts, no libraries) and outputs_mbed.cpp (Nano 33 BLE: the Servo library and attachInterrupt).
#pragma once
#include <stdint.h>

namespace outputs {
void begin();                                     // start frames at neutral, start RC capture
void write(uint16_t throttle_us, uint16_t steering_us);  // taken at the next frame start
uint32_t frames_started();                        // frames begun since begin() (wraps)
// The latest complete RC pulse on channel 0 (throttle) or 1 (steering) since the last call, in
// microseconds, or 0 when none arrived.
uint16_t take_rc_pulse(uint8_t channel);
}  // namespace outputs
