# The ROAR Junior's settings: edit, then put them on the robot (firmware/micropython/README.md).

# Wi-Fi: join this network; with WIFI_SSID = "" the robot opens its own network instead
WIFI_SSID = ""
WIFI_PASSWORD = ""
AP_SSID = "roar-junior"  # the robot's own network (its address is then 192.168.4.1)
AP_PASSWORD = "roarjunior"  # at least 8 characters

# Pins, as the ROAR Junior is wired (ESP32-CAM GPIO numbers)
ENABLE_LEFT = 12  # ENA: left side PWM
LEFT_IN1 = 13  # IN1: left forward
LEFT_IN2 = 15  # IN2: left reverse
RIGHT_IN1 = 14  # IN3: right forward
RIGHT_IN2 = 2  # IN4: right reverse
ENABLE_RIGHT = 16  # ENB: right side PWM
# The ultrasonic ranger is on the serial pins (TX = GPIO1, RX = GPIO3): once the robot takes
# them, the serial console stops. It reads the console for 3 s after a reset first (the
# protocol's junior serial_window_us), so a computer can still stop it or set its key.
ULTRASONIC_TRIGGER = 3
ULTRASONIC_ECHO = 1
KEY_FILE = "/roar_key.bin"  # signed control's key and session (set with: roar key set serial://PORT)
