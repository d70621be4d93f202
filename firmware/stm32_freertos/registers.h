// The STM32 peripheral registers the AnyFC F7 glue touches (STM32F745: reference manual RM0385),
// so the board builds with nothing but arm-none-eabi-gcc. Addresses of RCC, GPIO, TIM2-5, USART1/
// 3/6, ADC1, SPI1, IWDG and the core peripherals (SysTick, NVIC, DWT) are the same on the STM32F4
// (RM0090), which the emulator build (ROAR_STM32F4, QEMU's netduinoplus2) runs; the USART
// register layout is not, so it is chosen here.
#pragma once
#include <stdint.h>

namespace reg {

inline volatile uint32_t& at(uint32_t address) { return *reinterpret_cast<volatile uint32_t*>(address); }

constexpr uint32_t kRcc = 0x40023800, kGpioA = 0x40020000;
constexpr uint32_t kTim2 = 0x40000000, kTim3 = 0x40000400, kTim5 = 0x40000C00, kIwdg = 0x40003000;
constexpr uint32_t kUsart1 = 0x40011000, kUsart3 = 0x40004800, kUsart6 = 0x40011400;
constexpr uint32_t kAdc1 = 0x40012000, kSpi1 = 0x40013000;

// RCC
constexpr uint32_t kAhb1Enr = 0x30, kApb1Enr = 0x40, kApb2Enr = 0x44;
constexpr uint32_t kApb1Tim2 = 1u << 0, kApb1Tim3 = 1u << 1, kApb1Tim5 = 1u << 3, kApb1Usart3 = 1u << 18;
constexpr uint32_t kApb2Usart1 = 1u << 4, kApb2Usart6 = 1u << 5, kApb2Adc1 = 1u << 8, kApb2Spi1 = 1u << 12;
// GPIO
constexpr uint32_t kModer = 0x00, kOdr = 0x14, kBsrr = 0x18, kAfrl = 0x20, kAfrh = 0x24;
// General-purpose timers
constexpr uint32_t kCr1 = 0x00, kSmcr = 0x08, kSr = 0x10, kEgr = 0x14, kCcmr1 = 0x18, kCcmr2 = 0x1C, kCcer = 0x20,
                   kCnt = 0x24, kPsc = 0x28, kArr = 0x2C, kCcr2 = 0x38, kCcr4 = 0x40;
// USART: control bits are where both families have them, the registers are not
#if ROAR_STM32F4
constexpr uint32_t kUsartStatus = 0x00, kUsartRdr = 0x04, kUsartTdr = 0x04, kUsartBrr = 0x08, kUsartCr1 = 0x0C,
                   kUsartCr2 = 0x10, kUsartEnable = 1u << 13, kUsartRxInvert = 0;  // F4: no inversion (board inverter)
#else
constexpr uint32_t kUsartCr1 = 0x00, kUsartCr2 = 0x04, kUsartBrr = 0x0C, kUsartStatus = 0x1C, kUsartClear = 0x20,
                   kUsartRdr = 0x24, kUsartTdr = 0x28, kUsartEnable = 1u << 0, kUsartRxInvert = 1u << 16;
#endif
constexpr uint32_t kUsartRe = 1u << 2, kUsartTe = 1u << 3, kUsartRxneie = 1u << 5, kUsartTxeie = 1u << 7,
                   kUsartParity = 1u << 10, kUsartNineBits = 1u << 12, kUsartTwoStop = 2u << 12;
constexpr uint32_t kStatusErrors = 0xF, kStatusRxne = 1u << 5, kStatusTxe = 1u << 7;
// ADC1 (single conversion), SPI1 (master)
constexpr uint32_t kAdcSr = 0x00, kAdcCr2 = 0x08, kAdcSmpr1 = 0x0C, kAdcSqr3 = 0x34, kAdcDr = 0x4C;
constexpr uint32_t kAdcOn = 1u << 0, kAdcStart = 1u << 30, kAdcEoc = 1u << 1;
constexpr uint32_t kSpiCr1 = 0x00, kSpiCr2 = 0x04, kSpiSr = 0x08, kSpiDr = 0x0C, kSpiRxne = 1u << 0, kSpiTxe = 1u << 1;
// Independent watchdog: key, prescaler, reload; clocked by the ~32 kHz LSI
constexpr uint32_t kIwdgKr = 0x00, kIwdgPr = 0x04, kIwdgRlr = 0x08;
constexpr uint32_t kIwdgStart = 0xCCCC, kIwdgUnlock = 0x5555, kIwdgFeed = 0xAAAA;
// Core peripherals: SysTick, NVIC (enable, priority), FPU access, DWT cycle counter
constexpr uint32_t kSysTickCtrl = 0xE000E010, kSysTickLoad = 0xE000E014, kSysTickVal = 0xE000E018;
constexpr uint32_t kNvicIser = 0xE000E100, kNvicIpr = 0xE000E400, kCpacr = 0xE000ED88;
constexpr uint32_t kDemcr = 0xE000EDFC, kDemcrTrcena = 1u << 24;
constexpr uint32_t kDwtCtrl = 0xE0001000, kDwtCyccnt = 0xE0001004, kDwtLar = 0xE0001FB0;
constexpr uint32_t kDwtCyccntEna = 1u << 0, kDwtUnlockKey = 0xC5ACCE55;
// Interrupt numbers (the same on the F405 and the F745)
constexpr uint32_t kIrqUsart1 = 37, kIrqUsart3 = 39, kIrqUsart6 = 71;

inline uint32_t gpio_base(char port) { return kGpioA + static_cast<uint32_t>(port - 'A') * 0x400u; }

}  // namespace reg
