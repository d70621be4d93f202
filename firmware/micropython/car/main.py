# Runs at boot: the ESP32-CAM car's program (car_app.py), settings in config.py.
import asyncio

import car_app

asyncio.run(car_app.main())
