# Runs at boot: the ROAR Junior's program (junior_app.py), settings in config.py.
import asyncio

import junior_app

asyncio.run(junior_app.main())
