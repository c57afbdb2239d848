"""The optimal-path reference of SPL: grid shortest paths (paper Sec. IV; docs/metrics.md).

- :mod:`fftnav.optimal.gridgraph` - move sets, the grid graph, batched exact Dijkstra
  (``shortest_paths``), ``UnreachableGoalError``;
- :mod:`fftnav.optimal.astar` - readable 8-connected grid A* (the reference implementation);
- :mod:`fftnav.optimal.geodesic` - near-Euclidean 32-connected geodesic lengths;
- :mod:`fftnav.optimal.gridsearch` - optional numba: compiled A* for the reference lengths;
- :mod:`fftnav.optimal.reference` - ``optimal_lengths(world, r0_m=...)`` for an episode.

Submodules are imported explicitly (``from fftnav.optimal.reference import optimal_lengths``),
so importing the package stays cheap.
"""
