"""``python -m fogbench``: the command line (:mod:`fogbench.cli`)."""

import sys

from fogbench.cli import main

sys.exit(main())
