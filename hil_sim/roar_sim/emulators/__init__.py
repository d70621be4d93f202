"""Real firmware images and programs run on emulated chips: the Nano's ELF in simavr, the STM32
images in QEMU, the MicroPython boards' programs in MicroPython's WebAssembly runtime."""
