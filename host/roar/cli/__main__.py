import sys

from roar.cli.main import main

sys.exit(main())
