// Reset handler and vector table for the STM32F745 (and, in the emulator build, the STM32F405:
// the interrupts used here have the same numbers on both), without vendor startup files.
#include <stdint.h>

extern "C" {
extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _estack;
extern void (*__init_array_start[])();
extern void (*__init_array_end[])();
int main();

void Reset_Handler() {
  *reinterpret_cast<volatile uint32_t*>(0xE000ED88) |= 0xFu << 20;  // CPACR: the FPU on (hard-float ABI)
  for (uint32_t *src = &_sidata, *dst = &_sdata; dst < &_edata;) *dst++ = *src++;
  for (uint32_t* dst = &_sbss; dst < &_ebss;) *dst++ = 0;
  for (void (**ctor)() = __init_array_start; ctor < __init_array_end; ++ctor) (*ctor)();
  main();
  for (;;) {
  }
}

void Default_Handler() {
  for (;;) {
  }
}

// Handlers a build may define (the RTOS glue, the HAL); the rest stop in Default_Handler.
void SVC_Handler() __attribute__((weak, alias("Default_Handler")));
void PendSV_Handler() __attribute__((weak, alias("Default_Handler")));
void SysTick_Handler() __attribute__((weak, alias("Default_Handler")));
void USART1_IRQHandler() __attribute__((weak, alias("Default_Handler")));
void USART3_IRQHandler() __attribute__((weak, alias("Default_Handler")));
void USART6_IRQHandler() __attribute__((weak, alias("Default_Handler")));

using Handler = void (*)();
constexpr unsigned kCoreVectors = 16, kIrqs = 98;  // STM32F745: 98 interrupts (the F405 has 82)

struct VectorTable {
  uint32_t* initial_sp;
  Handler entries[kCoreVectors - 1 + kIrqs];  // from the reset vector on
};

constexpr VectorTable make_table() {
  VectorTable t = {&_estack, {}};
  for (unsigned i = 0; i < kCoreVectors - 1 + kIrqs; ++i) t.entries[i] = Default_Handler;
  const unsigned reserved[] = {7, 8, 9, 10, 13};
  for (unsigned v : reserved) t.entries[v - 1] = nullptr;
  t.entries[1 - 1] = Reset_Handler;
  t.entries[11 - 1] = SVC_Handler;
  t.entries[14 - 1] = PendSV_Handler;
  t.entries[15 - 1] = SysTick_Handler;
  t.entries[kCoreVectors - 1 + 37] = USART1_IRQHandler;
  t.entries[kCoreVectors - 1 + 39] = USART3_IRQHandler;
  t.entries[kCoreVectors - 1 + 71] = USART6_IRQHandler;
  return t;
}

// Constant-initialised, so it is in flash at boot, first (the linker script puts it there).
__attribute__((section(".isr_vector"), used)) constexpr VectorTable vector_table = make_table();

// Pure virtual calls cannot happen (every HAL method is defined); trap if one ever does.
void __cxa_pure_virtual() { Default_Handler(); }
}
