"""Planning: grid shortest paths (the optimal-path reference of SPL) and the navigation planner.

Optimal-path reference (paper Sec. IV; docs/metrics.md):

- :mod:`fftnav.planning.gridgraph` - move sets, the grid graph, batched exact Dijkstra
  (``shortest_paths``), ``UnreachableGoalError``;
- :mod:`fftnav.planning.astar` - readable 8-connected grid A* (the reference implementation);
- :mod:`fftnav.planning.geodesic` - near-Euclidean 32-connected geodesic lengths;
- :mod:`fftnav.planning.reference` - ``optimal_lengths(world, r0_m=...)`` for an episode.

Submodules are imported explicitly (``from fftnav.planning.reference import optimal_lengths``),
so importing the package stays cheap.
"""
