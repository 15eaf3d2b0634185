"""Joint values read by name: a driver's joint states come in any order (ur_robot_driver's
joint_state_broadcaster does not promise one), so nothing in densepack reads them by index."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np


def values_by_name(names: Sequence[str], values: Sequence[float], wanted: Sequence[str]
                   ) -> tuple[np.ndarray | None, tuple[str, ...]]:
    """The ``values`` of the joints ``wanted``, in that order, and the names missing (a name
    listed twice, or without a finite value, counts as missing). (None, missing) when any is."""
    index: dict[str, int] = {}
    twice = set()
    for i, name in enumerate(names):
        if name in index:
            twice.add(name)
        index[name] = i
    missing = tuple(n for n in wanted if n not in index or n in twice
                    or index[n] >= len(values) or not math.isfinite(values[index[n]]))
    if missing:
        return None, missing
    return np.array([float(values[index[n]]) for n in wanted]), ()
