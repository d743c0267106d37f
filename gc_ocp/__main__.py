"""``python -m gc_ocp``: the ``gc-ocp`` command (as ``python -m gc_ocp.cli``)."""

import sys

from gc_ocp.cli import main

sys.exit(main())
