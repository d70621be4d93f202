// Pins of the Arduino Nano and Nano 33 BLE car (the same header pins on both boards), in one place.
#pragma once
#include <stdint.h>

namespace pins {
constexpr uint8_t kThrottleOut = 5;  // D5: ESC signal
constexpr uint8_t kSteeringOut = 6;  // D6: steering servo signal
constexpr uint8_t kRcThrottleIn = 3;  // D3: RC receiver throttle channel
constexpr uint8_t kRcSteeringIn = 4;  // D4: RC receiver steering channel
}  // namespace pins
