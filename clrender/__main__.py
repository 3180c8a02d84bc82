"""`python -m clrender`: the same entry point as the console script (SIGINT handled from the start)."""

import sys

from .cli import main

sys.exit(main())
