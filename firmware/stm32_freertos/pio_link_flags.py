# PlatformIO extra script (env anyfc_f7): link with our own startup code only. build_flags reach
# the compiler, not the linker, and newlib's crt0 would want symbols our linker script does not
# define.
Import("env")  # noqa: F821 (provided by PlatformIO's SCons)

env.Append(LINKFLAGS=["-nostartfiles"])  # noqa: F821
