"""How programs reach a simulated robot, as they reach a real one: sim:// in-process, a serial pty,
the Junior's HTTP ports and camera, a virtual BLE radio, the phone's UDP streams, impaired links
and network namespaces."""
