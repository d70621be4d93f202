"""The robots' bodies and actuators in PyBullet: the 1/10 racecar, the Junior's chassis with its
L298N-driven gear motors, and the hobby ESC and steering servo the pulses drive."""
