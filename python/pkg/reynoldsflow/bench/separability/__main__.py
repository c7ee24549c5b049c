"""python -m reynoldsflow.bench.separability --out DIR [--quick] ... (see run.py)."""

import sys

from .run import main

if __name__ == "__main__":
    sys.exit(main())
