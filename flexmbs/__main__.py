"""``python -m flexmbs`` is the ``flexmbs`` command."""

import sys

try:
    from flexmbs.cli import main
except KeyboardInterrupt:  # Ctrl-C while Python starts: quietly, as the command would
    sys.exit(130)

sys.exit(main())
