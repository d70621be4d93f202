// AnyFC F7 (STM32F745VG) pins of the IARRC controller, in one place. Numbering as printed on the
// board: S1_OUT = PA3, S2_OUT = PA1 (both driven by TIM5, channels 4 and 2, so one timer makes
// the frames and TIM2 stays free as the fallback clock); UART1 = PA9/PA10 (the vision computer),
// UART3 = PB10/PB11 (the Bluetooth serial module), UART6 RX = PC7 (the SBUS receiver, inverted in
// the USART); the wheel encoder on TIM3 (S5/S6 pads PB4/PB5); the MPU6000 on SPI1 (PA5-7, CS PA4);
// the battery divider on PC0 (ADC1 channel 10); blue LED PB7.
#pragma once
#include <stdint.h>

namespace pins {
struct Pin {
  char port;
  uint8_t number;
  uint8_t alternate;  // alternate function number, 0 for plain GPIO
};
constexpr Pin kThrottleOut{'A', 3, 2};   // S1_OUT: TIM5 CH4 (AF2)
constexpr Pin kSteeringOut{'A', 1, 2};   // S2_OUT: TIM5 CH2 (AF2)
constexpr Pin kHostTx{'A', 9, 7};        // USART1 TX (AF7)
constexpr Pin kHostRx{'A', 10, 7};       // USART1 RX (AF7)
constexpr Pin kLinkTx{'B', 10, 7};       // USART3 TX (AF7)
constexpr Pin kLinkRx{'B', 11, 7};       // USART3 RX (AF7)
constexpr Pin kSbusRx{'C', 7, 8};        // USART6 RX (AF8)
constexpr Pin kEncoderA{'B', 4, 2};      // TIM3 CH1 (AF2)
constexpr Pin kEncoderB{'B', 5, 2};      // TIM3 CH2 (AF2)
constexpr Pin kGyroSck{'A', 5, 5};       // SPI1 (AF5)
constexpr Pin kGyroMiso{'A', 6, 5};
constexpr Pin kGyroMosi{'A', 7, 5};
constexpr Pin kGyroCs{'A', 4, 0};
constexpr Pin kBattery{'C', 0, 0};       // analog
constexpr uint8_t kBatteryAdcChannel = 10;
constexpr Pin kStatusLed{'B', 7, 0};
}  // namespace pins
