"""``python -m ocp_constraints ...`` is the ``ocp-constraints`` command."""
import sys

from .cli.main import main

sys.exit(main())
