"""The firmware core, as the simulator runs it: the binding of its C ABI (firmware/host/c_api.h)
through cffi, one module per part of the car logic, with the C++ classes' own names."""
