"""World presets, one TOML file per world kind; installed as the package ``fftnav.world.presets``.

This folder is the one home of the presets: pyproject.toml maps it into the wheel (and into
editable installs), and ``fftnav.world.kinds`` reads them with ``importlib.resources``.
"""
