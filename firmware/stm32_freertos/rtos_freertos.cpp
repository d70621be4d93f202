// The task table on FreeRTOS (ROAR_FREERTOS, the PlatformIO build): one statically allocated task
// per row of roar::kIarrcTasks at its priority, released every period with xTaskDelayUntil; a
// task that overran runs again at once and keeps its period from there, and the releases it
// missed are counted. Equal priorities share the CPU each tick (configUSE_TIME_SLICING).
#if ROAR_FREERTOS
#include "rtos.h"
#include "semphr.h"

namespace {

constexpr uint32_t kStackPoolWords = 3072;  // [words] the table's stacks, laid out in order
StackType_t stack_pool[kStackPoolWords];
StaticTask_t task_blocks[roar::kIarrcTaskCount];
StaticSemaphore_t mutex_block;
SemaphoreHandle_t mutex = nullptr;
roar::IarrcBoard* the_board = nullptr;

void task_main(void* arg) {
  const auto task = static_cast<roar::IarrcTask>(reinterpret_cast<uintptr_t>(arg));
  const TickType_t period = roar::kIarrcTasks[static_cast<uint8_t>(task)].period_us / (1000000 / rtos::kTickHz);
  TickType_t last = xTaskGetTickCount();
  for (;;) {
    the_board->run(task);
    if (xTaskDelayUntil(&last, period) == pdFALSE) {  // no wait: a release passed while it ran
      const TickType_t now = xTaskGetTickCount();
      the_board->overran(task, (now - last) / period + 1);
      last = now;
    }
  }
}

}  // namespace

extern "C" void vApplicationGetIdleTaskMemory(StaticTask_t** tcb, StackType_t** stack, configSTACK_DEPTH_TYPE* words) {
  static StaticTask_t idle_tcb;
  static StackType_t idle_stack[configMINIMAL_STACK_SIZE];
  *tcb = &idle_tcb;
  *stack = idle_stack;
  *words = configMINIMAL_STACK_SIZE;
}

namespace rtos {

void lock() { xSemaphoreTake(mutex, portMAX_DELAY); }
void unlock() { xSemaphoreGive(mutex); }
void critical_enter() { taskENTER_CRITICAL(); }
void critical_exit() { taskEXIT_CRITICAL(); }

void run(roar::IarrcBoard& board) {
  the_board = &board;
  mutex = xSemaphoreCreateMutexStatic(&mutex_block);
  uint32_t used = 0;
  for (uint8_t i = 0; i < roar::kIarrcTaskCount; ++i) {
    const roar::TaskSpec& t = roar::kIarrcTasks[i];
    configASSERT(used + t.stack_words <= kStackPoolWords);
    xTaskCreateStatic(task_main, t.name, t.stack_words, reinterpret_cast<void*>(static_cast<uintptr_t>(i)),
                      t.priority, stack_pool + used, &task_blocks[i]);
    used += t.stack_words;
  }
  vTaskStartScheduler();
  for (;;) {
  }
}

}  // namespace rtos
#endif
