"""Observation: the paper's FFT pipeline on one or many scans (pure numpy/scipy)."""
