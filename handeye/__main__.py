"""``python -m handeye ...`` (and ``torchrun --nproc-per-node N -m handeye learned run ...``): the command line."""

from __future__ import annotations

import sys

from handeye.cli import main

if __name__ == "__main__":
    sys.exit(main())
