"""``python -m fftnav`` is the ``fftnav`` command."""

import sys

from fftnav.cli import main

if __name__ == "__main__":
    sys.exit(main())
