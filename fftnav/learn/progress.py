"""The progress bar of ``fftnav learn``: learner samples, samples per second, running AR."""

from __future__ import annotations

import sys
import time
from typing import Any

from tqdm import tqdm

__all__ = ["ProgressBar"]


class ProgressBar:
    """A tqdm bar on stderr fed by :func:`fftnav.learn.train.train`'s ``progress`` calls.

    Its rate counts the samples of this invocation only (a resumed training's earlier samples
    are not in it); the running AR is over the training episodes finished so far.
    """

    def __init__(self, total: int, *, desc: str) -> None:
        self.bar = tqdm(total=total, unit="sample", unit_scale=True, desc=desc, file=sys.stderr)
        self.start = time.perf_counter()
        self.first: int | None = None

    def __call__(self, state: dict[str, Any]) -> None:
        if self.first is None:
            self.first = state["samples"]
        self.bar.n = min(state["samples"], self.bar.total)
        rate = (state["samples"] - self.first) / max(time.perf_counter() - self.start, 1e-9)
        self.bar.set_postfix_str(f"{rate:,.0f} samples/s, running AR {state['train_ar']:.2f} "
                                 f"over {state['episodes']} episodes", refresh=False)
        self.bar.refresh()

    def close(self) -> None:
        self.bar.close()
