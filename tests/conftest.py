"""Test-suite settings: property tests draw the same examples on every run and machine, so a
CI failure always reproduces (explore new examples with ``pytest --hypothesis-seed=N``)."""

from hypothesis import settings

settings.register_profile("fftnav", derandomize=True, deadline=None)
settings.load_profile("fftnav")
