# PlatformIO extra script (env anyfc_f7): build the FreeRTOS kernel that lib_deps fetched from its
# official repository (FreeRTOS is never copied into this project). lib_ignore keeps PlatformIO's
# library finder from compiling every port in it; this script compiles just the kernel files the
# controller uses, the Cortex-M7 r0p1 port (the STM32F745's core revision) and no heap (all of
# the controller's RTOS objects are static), against firmware/stm32_freertos/FreeRTOSConfig.h.
# The same files link offline in roar_sim.toolchains.arm.build_freertos (FREERTOS_SOURCES there).
import os
import sys

Import("env")  # noqa: F821 (provided by PlatformIO's SCons)

kernel = os.path.join(env.subst("$PROJECT_LIBDEPS_DIR"), env.subst("$PIOENV"), "FreeRTOS-Kernel")  # noqa: F821
if not os.path.isfile(os.path.join(kernel, "tasks.c")):
    sys.stderr.write(f"error: FreeRTOS-Kernel not found in {kernel}: run `pio pkg install -e anyfc_f7` online\n")
    env.Exit(1)  # noqa: F821
port = os.path.join(kernel, "portable", "GCC", "ARM_CM7", "r0p1")
board = os.path.join(env.subst("$PROJECT_DIR"), "firmware", "stm32_freertos")  # noqa: F821
env.Append(CPPPATH=[os.path.join(kernel, "include"), port, board])  # noqa: F821
env.BuildSources(  # noqa: F821
    os.path.join("$BUILD_DIR", "FreeRTOS"), kernel,
    src_filter=["-<*>", "+<tasks.c>", "+<list.c>", "+<queue.c>", "+<stream_buffer.c>",
                "+<portable/GCC/ARM_CM7/r0p1/port.c>"])
