"""Drive in circles for 12 seconds: python examples/circle.py [URL]
sim:// (default) is the simulated car; serial:///dev/ttyUSB0 or ble:// is a real one."""
import sys
import time

from roar import Vehicle

url = sys.argv[1] if len(sys.argv) > 1 else "sim://"
with Vehicle(url) as car:  # neutral is sent when the block ends, even on Ctrl-C
    print(f"driving in circles on {url} for 12 s (Ctrl-C stops)", flush=True)
    car.drive(throttle=0.3, steering=1.0)  # gentle throttle, full right lock
    time.sleep(12)
print("done: neutral sent, the car stops")
