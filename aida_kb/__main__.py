"""``python -m aida_kb`` runs the command line."""

import sys

from aida_kb.cli.main import main

sys.exit(main())
