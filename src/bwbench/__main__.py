"""``python -m bwbench``: the command line (``bwbench.cli``)."""

from bwbench.cli import main

raise SystemExit(main())
