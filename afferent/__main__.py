"""``python -m afferent`` runs the command-line interface."""

import sys

from afferent.cli import main

sys.exit(main())
