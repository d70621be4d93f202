// AnyFC F7 (STM32F745VG) car pins, in one place. Output and input numbering as printed on the
// board: S1_OUT = PA3, S2_OUT = PA1 (both driven by TIM5, channels 4 and 2, so one timer makes
// the frames and TIM2 stays free as the fallback clock), S1_IN = PB14, S2_IN = PB15,
// UART1 = PA9 (TX) / PA10 (RX), blue LED PB7.
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
constexpr Pin kRcThrottleIn{'B', 14, 0}; // S1_IN (capture comes with the FreeRTOS controller)
constexpr Pin kRcSteeringIn{'B', 15, 0}; // S2_IN
constexpr Pin kSerialTx{'A', 9, 7};      // USART1 TX (AF7)
constexpr Pin kSerialRx{'A', 10, 7};     // USART1 RX (AF7)
constexpr Pin kStatusLed{'B', 7, 0};
}  // namespace pins
