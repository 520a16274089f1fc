"""``python -m jaxcable.cli``: the same as the ``jaxcable`` command."""

import sys

from jaxcable.cli import main

sys.exit(main())
