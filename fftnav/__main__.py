"""``python -m fftnav`` is the ``fftnav`` command."""

from fftnav.cli import entry

if __name__ == "__main__":
    entry()
