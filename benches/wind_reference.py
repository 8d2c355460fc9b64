"""The wind-like power reference shared by the hub benchmarks (benches/hub_fmpy.py and the NREL
peer benches/nrel_peer.py): a seeded mean-reverting random walk at 1 s between 5 % and 100 % of
the rated power. Needs numpy only, so both virtual environments can import it."""

import numpy as np


def wind_reference(n, rated, seed=42):
    """`n` seconds of reference [W] between 5 % and 100 % of `rated` [W]."""
    rng = np.random.default_rng(seed)
    x, out = 0.6, np.empty(n)
    steps = rng.random(n) - 0.5
    for k in range(n):
        x = min(max(x + 0.001 * (0.6 - x) + 0.01 * steps[k], 0.05), 1.0)
        out[k] = x * rated
    return out
