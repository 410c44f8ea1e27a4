"""``python -m siftom.cli``: the same as the ``siftom`` command."""

import sys

from siftom.cli import main

sys.exit(main())
