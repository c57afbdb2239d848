"""Test-suite settings: property tests draw the same examples on every run and machine, so a
CI failure always reproduces (draw fresh examples with ``pytest --hypothesis-profile=default``)."""

from hypothesis import settings

settings.register_profile("fftnav", derandomize=True, deadline=None)
settings.load_profile("fftnav")
