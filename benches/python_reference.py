"""A straightforward Python/SciPy implementation of the same module model, as a peer for the
benchmark: G(s) discretised by zero-order hold (scipy.signal.cont2discrete), the rising-rate
limit applied per step, energy and hydrogen by the rectangle rule.

This is what a user would write in a notebook; it is not exact between samples (the rate limit
only acts at the sample instants), which is one reason the FMU exists.
"""

import json
from pathlib import Path

import numpy as np
from scipy.signal import cont2discrete, tf2ss

#: The paper's Table I and operating window, name -> value, from the tests' one copy.
PAPER = {
    row["name"]: row["value"]
    for row in json.loads(
        (Path(__file__).resolve().parent.parent / "tests" / "data" / "table_i.json").read_text(encoding="utf-8")
    )
}


def simulate(setpoints, dt=1.0, p=PAPER):
    """Current, power, energy [J] and hydrogen [Nl] for a setpoint series at step dt [s]."""
    k = p["gain"]
    num = [k * p["tauZero"], k]
    den = np.polymul([p["tauPole1"], 1.0], [p["tauPole2"], 1.0])
    a, b, c, d = tf2ss(num, den)
    ad, bd, cd, dd, _ = cont2discrete((a, b, c, d), dt, method="zoh")
    bd = bd[:, 0]
    cd = cd[0]
    dd = float(dd[0, 0])
    u0 = float(np.clip(setpoints[0], p["minSetpoint"], p["maxSetpoint"]))
    # Steady state: x = (I - Ad)^-1 Bd u0.
    x = np.linalg.solve(np.eye(2) - ad, bd * u0)
    current = float(cd @ x + dd * u0)
    energy = 0.0
    hydrogen = 0.0
    currents = np.empty(len(setpoints))
    powers = np.empty(len(setpoints))
    for n, sp in enumerate(setpoints):
        u = min(max(sp, p["minSetpoint"]), p["maxSetpoint"])
        x = ad @ x + bd * u
        unlimited = float(cd @ x)
        current = min(current + p["rampUpLimit"] * dt, unlimited)
        voltage = p["voltageIntercept"] + p["ohmicResistance"] * current
        power = voltage * current
        energy += power * dt
        hydrogen += p["h2Coefficient"] * current * dt / 3600.0
        currents[n] = current
        powers[n] = power
    return currents, powers, energy, hydrogen
