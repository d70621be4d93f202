/* FreeRTOS configuration of the AnyFC F7 IARRC controller (used only with ROAR_FREERTOS, the
 * PlatformIO build, where lib_deps brings the kernel). Everything is statically allocated: no
 * heap. Pre-emptive, with time slicing among equal priorities; 1 kHz tick. */
#ifndef FREERTOS_CONFIG_H
#define FREERTOS_CONFIG_H

#define configCPU_CLOCK_HZ 16000000UL /* [Hz] HSI: the glue runs the chip on its reset clock */
#define configTICK_RATE_HZ 1000       /* rtos::kTickHz */
#define configUSE_PREEMPTION 1
#define configUSE_TIME_SLICING 1
#define configUSE_PORT_OPTIMISED_TASK_SELECTION 1
#define configMAX_PRIORITIES 6 /* the task table uses 1..5 */
#define configMINIMAL_STACK_SIZE 128
#define configMAX_TASK_NAME_LEN 12
#define configTICK_TYPE_WIDTH_IN_BITS TICK_TYPE_WIDTH_32_BITS
#define configIDLE_SHOULD_YIELD 1
#define configSUPPORT_STATIC_ALLOCATION 1
#define configSUPPORT_DYNAMIC_ALLOCATION 0
#define configUSE_MUTEXES 1
#define configUSE_STREAM_BUFFERS 1
#define configUSE_TIMERS 0
#define configUSE_IDLE_HOOK 0
#define configUSE_TICK_HOOK 0
#define configCHECK_FOR_STACK_OVERFLOW 0
#define configUSE_TRACE_FACILITY 0
#define INCLUDE_xTaskDelayUntil 1
#define INCLUDE_vTaskDelay 1

/* Cortex-M7, 4 priority bits. Interrupts that call FreeRTOS (the USARTs) must have a priority
 * value at or above configMAX_SYSCALL_INTERRUPT_PRIORITY (5 << 4); iarrc_hal.cpp sets 6 << 4. */
#define configPRIO_BITS 4
#define configKERNEL_INTERRUPT_PRIORITY (15 << (8 - configPRIO_BITS))
#define configMAX_SYSCALL_INTERRUPT_PRIORITY (5 << (8 - configPRIO_BITS))

/* A failed assertion stops here; the watchdog then resets the board at neutral. */
#define configASSERT(x) \
  if (!(x)) {           \
    for (;;) {          \
    }                   \
  }

/* The port's handlers under the vector table's names (startup.cpp). */
#define vPortSVCHandler SVC_Handler
#define xPortPendSVHandler PendSV_Handler
#define xPortSysTickHandler SysTick_Handler

#endif /* FREERTOS_CONFIG_H */
