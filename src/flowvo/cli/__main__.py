"""``python -m flowvo.cli``: the ``flowvo`` command."""

import sys

from flowvo.cli import main

sys.exit(main())
