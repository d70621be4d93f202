// AnyFC F7 (STM32F745): the IARRC controller. The core's IarrcBoard holds every decision and
// every task body; this folder is its HAL (iarrc_hal.cpp) and the RTOS that runs the task table
// (rtos_freertos.cpp on the board, rtos_systick.cpp offline and in the emulator).
#include "iarrc_hal.h"
#include "rtos.h"

namespace {
AnyFcHal hal;
roar::IarrcBoard board(hal);
}  // namespace

uint32_t rtos::core_hz() { return AnyFcHal::kCoreHz; }

int main() {
  hal.begin();
  board.begin();
  rtos::run(board);
}
