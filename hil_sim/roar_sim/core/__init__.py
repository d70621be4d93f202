"""The firmware core, as the simulator runs it: the binding of its C ABI (firmware/host/c_api.h)
through cffi, one module per part of the car logic, with the C++ classes' own names; and the
board's time: lockstep (the firmware loop and physics periods every robot shares) and rtos (a
fixed-priority scheduler with FreeRTOS's rules for the IARRC car's tasks)."""
