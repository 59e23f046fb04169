"""`python -m backend.cli` runs the `wheelscan` command line."""

import sys

from backend.cli import main

sys.exit(main())
