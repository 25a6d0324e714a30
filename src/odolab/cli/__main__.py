"""``python -m odolab.cli``."""

import sys

from odolab.cli import main

sys.exit(main())
