"""``python -m ocp_constraints ...`` is the ``ocp-constraints`` command."""
import sys

from .cli import main

sys.exit(main())
