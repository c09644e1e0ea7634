"""``python -m reference_impl.bench ADAPTER ...``: the ``hcv bench`` command stand-alone."""

import sys

from reference_impl.cli.bench import main

if __name__ == "__main__":
    sys.exit(main())
