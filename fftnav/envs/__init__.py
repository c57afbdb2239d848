"""Learning environments: :class:`SwarmNavEnv`, the swarm as a PettingZoo ``ParallelEnv``, and
:class:`DecisionEnv`, the Bug planner's side decisions as a Gymnasium ``Env``.

Needs the optional extra ``pip install fftnav[marl]`` (``pettingzoo``, ``gymnasium``).
"""

from fftnav.errors import import_extra

for _module in ("gymnasium", "pettingzoo"):
    import_extra(_module, extra="marl", needed_for="the multi-agent environments (fftnav.envs)")

from fftnav.envs.decision_env import DecisionEnv  # noqa: E402
from fftnav.envs.swarm_env import MESSAGE_BYTES, Observations, Rewards, SwarmNavEnv  # noqa: E402

__all__ = ["MESSAGE_BYTES", "DecisionEnv", "Observations", "Rewards", "SwarmNavEnv"]
