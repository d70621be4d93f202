// Pins of the ESP32-CAM (AI-Thinker) car, as ROAR wires it, in one place.
#pragma once
#include <stdint.h>

namespace pins {
constexpr uint8_t kThrottleOut = 14;  // GPIO14: ESC signal
constexpr uint8_t kSteeringOut = 2;   // GPIO2: steering servo signal
constexpr uint8_t kStatusLed = 33;    // red LED, active low: lit while a host is connected
// LEDC channels 2 and 3 share timer 1; timer 0 stays free for the camera's XCLK.
constexpr uint8_t kThrottleChannel = 2;
constexpr uint8_t kSteeringChannel = 3;
}  // namespace pins
