"""How the robots navigate: the Bug planner, decision policies and controllers.

- :mod:`fftnav.navigation.bug` - ``BugPlanner``, the planner's state machine over the states of
  :class:`fftnav.states.State` (docs/planner.md); :mod:`~fftnav.navigation.memory` (what it
  remembers of each robot, and its counters), :mod:`~fftnav.navigation.ownmap` (each robot's map
  of its own scans, the escape and guided ways) and :mod:`~fftnav.navigation.kernels` (their
  compiled loops: the corridor test and the map's marking, optional numba);
- :mod:`fftnav.navigation.policies` - decision policies (which side), ``register_policy``;
- :mod:`fftnav.navigation.messages` - what a policy's robots broadcast and how they read it (one
  message kind instance per episode);
- :mod:`fftnav.navigation.controllers` - the controller API (``Controller``, ``SwarmStep``,
  ``Packet``), ``register_controller``; :mod:`~fftnav.navigation.baselines` (vfh, ftg, fft-go);
- :mod:`fftnav.navigation.bugcontrol` - ``BugController``, the Bug planner with a decision
  policy, the default controller; :mod:`~fftnav.navigation.decider` (P_s and the fused P)
  and :mod:`~fftnav.navigation.collab` (``collab``'s wall-segment messages);
- :mod:`fftnav.navigation.resolve` - one name -> a decision policy or a controller.

Submodules are imported explicitly, so importing the package stays cheap.
"""
