"""Builds of the firmware with this machine's compilers, no PlatformIO: the core for the host
(native), the classic Nano's image (avr), the AnyFC F7's and the QEMU test images (arm), and what
each image costs in flash and RAM (sizes)."""
