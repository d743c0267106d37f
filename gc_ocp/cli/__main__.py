"""``python -m gc_ocp.cli``: the same as the ``gc-ocp`` command."""

import sys

from gc_ocp.cli import main

sys.exit(main())
