// The few STM32F745 peripheral registers this skeleton touches (reference manual RM0385), so
// the board builds with nothing but arm-none-eabi-gcc. The core-peripheral (DWT, DEMCR), TIM2,
// RCC enable and IWDG addresses are the same on the STM32F4, which the emulator test runs. The
// FreeRTOS controller (a later issue) will use ST's CMSIS headers through PlatformIO instead.
#pragma once
#include <stdint.h>

namespace reg {

inline volatile uint32_t& at(uint32_t address) { return *reinterpret_cast<volatile uint32_t*>(address); }

constexpr uint32_t kRcc = 0x40023800, kGpioA = 0x40020000, kGpioB = 0x40020400;
constexpr uint32_t kTim2 = 0x40000000, kTim5 = 0x40000C00, kUsart1 = 0x40011000, kIwdg = 0x40003000;

// RCC
constexpr uint32_t kAhb1Enr = 0x30, kApb1Enr = 0x40, kApb2Enr = 0x44;
constexpr uint32_t kApb1Tim2 = 1u << 0, kApb1Tim5 = 1u << 3;
// GPIO
constexpr uint32_t kModer = 0x00, kOdr = 0x14, kAfrl = 0x20, kAfrh = 0x24;
// General-purpose timers
constexpr uint32_t kCr1 = 0x00, kSr = 0x10, kEgr = 0x14, kCcmr1 = 0x18, kCcmr2 = 0x1C, kCcer = 0x20, kCnt = 0x24,
                   kPsc = 0x28, kArr = 0x2C, kCcr2 = 0x38, kCcr4 = 0x40;
// USART (F7 layout)
constexpr uint32_t kUsartCr1 = 0x00, kUsartBrr = 0x0C, kUsartIsr = 0x1C, kUsartRdr = 0x24, kUsartTdr = 0x28;
constexpr uint32_t kIsrRxne = 1u << 5, kIsrTxe = 1u << 7;
// Independent watchdog: key, prescaler, reload; clocked by the ~32 kHz LSI
constexpr uint32_t kIwdgKr = 0x00, kIwdgPr = 0x04, kIwdgRlr = 0x08;
constexpr uint32_t kIwdgStart = 0xCCCC, kIwdgUnlock = 0x5555, kIwdgFeed = 0xAAAA;
// Debug: trace enable, and the DWT cycle counter with its lock access register (Cortex-M7)
constexpr uint32_t kDemcr = 0xE000EDFC, kDemcrTrcena = 1u << 24;
constexpr uint32_t kDwtCtrl = 0xE0001000, kDwtCyccnt = 0xE0001004, kDwtLar = 0xE0001FB0;
constexpr uint32_t kDwtCyccntEna = 1u << 0, kDwtUnlockKey = 0xC5ACCE55;

inline uint32_t gpio_base(char port) { return kGpioA + static_cast<uint32_t>(port - 'A') * 0x400u; }

}  // namespace reg
