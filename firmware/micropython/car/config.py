# The ESP32-CAM car's settings: edit, then put them on the car (firmware/micropython/README.md).

NAME = "ROAR Car"  # the Bluetooth name it advertises (a host finds it with ble:// or roar scan)
KEY_FILE = "/roar_key.bin"  # signed control's key and session (set with: roar key set serial://PORT)

# Pins (ESP32-CAM GPIO numbers), as ROAR wires the car
THROTTLE_PIN = 14  # ESC signal
STEERING_PIN = 2  # steering servo signal
STATUS_LED_PIN = 33  # red LED, lit (low) while a host is connected

# Trims and end-points [us]: the pulse for a command is command + trim, kept within min..max.
THROTTLE_TRIM_US = 0
THROTTLE_MIN_US = 1000
THROTTLE_MAX_US = 2000
STEERING_TRIM_US = 0
STEERING_MIN_US = 1000
STEERING_MAX_US = 2000
