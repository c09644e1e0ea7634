"""``python -m reference_impl.cli``: the ``hcv`` command."""

import sys

from reference_impl.cli import main

sys.exit(main())
