"""Benchmarks: pipeline latency, simulation speed, optimal-path timing."""
