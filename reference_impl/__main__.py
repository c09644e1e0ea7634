"""``python -m reference_impl``: the ``hcv`` command."""

import sys

from reference_impl.cli import main

sys.exit(main())
