// Pins of the ROAR Junior (ESP32-CAM driving an L298N), as the original robot is wired.
#pragma once
#include <stdint.h>

namespace pins {
constexpr uint8_t kEnableLeft = 12;   // ENA: left side PWM
constexpr uint8_t kLeftIn1 = 13;      // IN1: left forward
constexpr uint8_t kLeftIn2 = 15;      // IN2: left reverse
constexpr uint8_t kRightIn1 = 14;     // IN3: right forward
constexpr uint8_t kRightIn2 = 2;      // IN4: right reverse
constexpr uint8_t kEnableRight = 16;  // ENB: right side PWM
// The ultrasonic ranger sits on the UART0 pins (TX = GPIO1, RX = GPIO3): Serial is used only
// in the window after a reset (key lines), before the ranger takes them.
constexpr uint8_t kUltrasonicTrigger = 3;
constexpr uint8_t kUltrasonicEcho = 1;
constexpr uint8_t kLeftChannel = 14;  // LEDC channels of the enable pins (timer 7)
constexpr uint8_t kRightChannel = 15;
}  // namespace pins
