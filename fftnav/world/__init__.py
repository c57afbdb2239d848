"""Worlds: the world model, seeded generation, analytic geometry, occupancy grids, scenes."""
