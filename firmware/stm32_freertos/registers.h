// The few STM32F745 peripheral registers this skeleton touches (reference manual RM0385), so
// the board builds with nothing but arm-none-eabi-gcc. The FreeRTOS controller (a later
// issue) will use ST's CMSIS headers through PlatformIO instead.
#pragma once
#include <stdint.h>

namespace reg {

inline volatile uint32_t& at(uint32_t address) { return *reinterpret_cast<volatile uint32_t*>(address); }

constexpr uint32_t kRcc = 0x40023800, kGpioA = 0x40020000, kGpioB = 0x40020400;
constexpr uint32_t kTim2 = 0x40000000, kTim5 = 0x40000C00, kUsart1 = 0x40011000;
constexpr uint32_t kDwt = 0xE0001000, kDemcr = 0xE000EDFC;

// RCC
constexpr uint32_t kAhb1Enr = 0x30, kApb1Enr = 0x40, kApb2Enr = 0x44;
// GPIO
constexpr uint32_t kModer = 0x00, kOdr = 0x14, kAfrl = 0x20, kAfrh = 0x24;
// General-purpose timers
constexpr uint32_t kCr1 = 0x00, kSr = 0x10, kEgr = 0x14, kCcmr1 = 0x18, kCcmr2 = 0x1C, kCcer = 0x20,
                   kPsc = 0x28, kArr = 0x2C, kCcr2 = 0x38, kCcr4 = 0x40;
// USART (F7 layout)
constexpr uint32_t kUsartCr1 = 0x00, kUsartBrr = 0x0C, kUsartIsr = 0x1C, kUsartRdr = 0x24, kUsartTdr = 0x28;
constexpr uint32_t kIsrRxne = 1u << 5, kIsrTxe = 1u << 7;

inline uint32_t gpio_base(char port) { return kGpioA + static_cast<uint32_t>(port - 'A') * 0x400u; }

}  // namespace reg
