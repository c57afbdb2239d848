"""``python -m fftnav`` is the ``fftnav`` command."""

import sys

from fftnav.cli import main

sys.exit(main())
