"""``python -m flexmbs`` is the ``flexmbs`` command."""

import sys

from flexmbs.cli import main

sys.exit(main())
