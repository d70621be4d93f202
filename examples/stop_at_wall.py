"""Drive ahead, print where the car is and how fast, and brake when the lidar sees a wall.
Needs a car with a lidar: the simulator.    python examples/stop_at_wall.py [sim://oval]"""
import sys
import time

from roar import Vehicle

with Vehicle(sys.argv[1] if len(sys.argv) > 1 else "sim://oval") as car:
    car.wait_armed(timeout_s=5)
    car.drive(throttle=0.3)
    while min(car.lidar()[500:580]) > 1.2:  # [m] the beams straight ahead
        s = car.state()
        print(f"x {s.x_m:5.2f} m   y {s.y_m:5.2f} m   {s.speed_m_s:4.2f} m/s", flush=True)
        time.sleep(0.1)
    car.drive(throttle=-0.6)  # the firmware's brake sequence turns this reverse into braking
    while car.state().speed_m_s > 0.05:
        time.sleep(0.02)
    print(f"stopped {min(car.lidar()[500:580]):.2f} m from the wall")
