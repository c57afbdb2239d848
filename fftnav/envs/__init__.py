"""Learning environments: :class:`SwarmNavEnv`, the swarm as a PettingZoo ``ParallelEnv``.

Needs the optional extra ``pip install fftnav[marl]`` (``pettingzoo``, ``gymnasium``).
"""

try:
    from fftnav.envs.swarm_env import MESSAGE_BYTES, Observations, Rewards, SwarmNavEnv
except ImportError as exc:  # pragma: no cover - depends on the installed extras
    if exc.name not in ("pettingzoo", "gymnasium"):
        raise
    raise ImportError(f"fftnav.envs needs the optional extra: pip install 'fftnav[marl]' "
                      f"({exc.name} is not installed)", name=exc.name) from None

__all__ = ["MESSAGE_BYTES", "Observations", "Rewards", "SwarmNavEnv"]
