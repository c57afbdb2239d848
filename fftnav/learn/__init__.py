"""Training learned methods: ``fftnav learn CONFIG --out DIR`` (docs/learning.md).

``config`` (the TOML schema), ``batch`` (a swarm's robots as learner slots, the observations a
learned controller sees at run time), ``validate`` (AR and SPL of the exported network on fixed
maps) and ``train`` (PPO through Stable-Baselines3, the extra ``learn``, imported inside
functions: the package imports without it).
"""

from fftnav.learn.config import LearnConfig, load_learn_config, parse_learn_config

__all__ = ["LearnConfig", "load_learn_config", "parse_learn_config"]
