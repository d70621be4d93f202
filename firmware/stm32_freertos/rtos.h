// What the AnyFC F7 glue needs from an RTOS, in one place. With ROAR_FREERTOS (the PlatformIO
// build; FreeRTOS comes through lib_deps): one FreeRTOS task per row of roar::kIarrcTasks, each
// released with xTaskDelayUntil, a mutex for the controller, stream buffers from the USART
// interrupts. Without it (the offline build and the emulated Cortex-M4): the same task table
// run to completion in priority order from SysTick, and lock-free rings from the interrupts.
#pragma once
#include <stddef.h>
#include <stdint.h>

#include "roar/iarrc_board.h"

#if ROAR_FREERTOS
#include "FreeRTOS.h"
#include "stream_buffer.h"
#include "task.h"
#else
#include "roar/spsc_bytes.h"
#endif

namespace rtos {

constexpr uint32_t kTickHz = 1000;  // [Hz] the scheduler's tick; every task period is whole ticks

// Bytes from one interrupt to one task. A push goes in whole or not at all (an SBUS byte and
// its arrival time stay together).
template <uint16_t N>
class IsrBytes {
 public:
#if ROAR_FREERTOS
  void begin() { handle_ = xStreamBufferCreateStatic(N, 1, storage_, &buffer_); }
  bool push_from_isr(const uint8_t* data, size_t n) {
    if (xStreamBufferSpacesAvailable(handle_) < n) return false;  // the ISR is the only writer
    BaseType_t woken = pdFALSE;
    xStreamBufferSendFromISR(handle_, data, n, &woken);
    portYIELD_FROM_ISR(woken);
    return true;
  }
  size_t pop(uint8_t* out, size_t cap) { return xStreamBufferReceive(handle_, out, cap, 0); }

 private:
  StaticStreamBuffer_t buffer_;
  uint8_t storage_[N + 1];
  StreamBufferHandle_t handle_ = nullptr;
#else
  void begin() {}
  bool push_from_isr(const uint8_t* data, size_t n) { return ring_.push(data, n); }
  size_t pop(uint8_t* out, size_t cap) { return ring_.pop(out, cap); }

 private:
  roar::SpscBytes<N> ring_;
#endif
};

void lock();            // the controller, shared by the tasks
void unlock();
void critical_enter();  // a few instructions that no task or interrupt may split
void critical_exit();
uint32_t core_hz();     // [Hz] what SysTick counts
#if !ROAR_FREERTOS
roar::RawMicros systick_us();  // [us] since run() began, from SysTick (the emulator's clock)
#endif
[[noreturn]] void run(roar::IarrcBoard& board);  // starts the task table; never returns

}  // namespace rtos
