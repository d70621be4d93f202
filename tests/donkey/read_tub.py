"""Read a tub with DonkeyCar's own Tub class and print what it holds as one JSON line ("TUB {...}").
It runs in DonkeyCar's environment (.venv-donkey: Python 3.11, numpy < 2; made by `make test`), not
the project's: python read_tub.py TUB_FOLDER"""

import json
import sys

from donkeycar.parts.tub_v2 import Tub
from PIL import Image

tub = Tub(sys.argv[1], read_only=True)
records = list(tub)
fields = ("user/angle", "user/throttle", "user/mode", "_index", "_timestamp_ms", "_session_id")
print("TUB " + json.dumps({
    "len": len(tub), "inputs": tub.manifest.inputs, "types": tub.manifest.types,
    "records": [{**{k: r[k] for k in fields},
                 "image_size": list(Image.open(f"{tub.images_base_path}/{r['cam/image_array']}").size)}
                for r in records]}))
