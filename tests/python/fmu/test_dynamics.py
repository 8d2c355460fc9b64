"""Dynamics of the AEM electrolyser FMU against closed-form expectations.

Model (paper, Table I), with u the setpoint clamped to [minSetpoint, maxSetpoint]:

    I_tf = K G(s) u,   G(s) = (tz s + 1) / ((t1 s + 1)(t2 s + 1))
         = K a/(t1 s + 1) + K b/(t2 s + 1),   a = (tz - t1)/(t2 - t1),  b = 1 - a
    I(t) = min(I(t0) + r (t - t0),  min_{s in [t0, t]} I_tf(s) + r (t - s))   (rising-rate limit)
    V = V0 + R I,   P = V I,   F = c I [Nl/h],   E = int P dt,   N = c int I dt / 3600

After a step u0 -> u1 from steady state, the unlimited current is a sum of exponentials,

    I_tf(t) = K u1 + K (u0 - u1) (a e^(-t/t1) + b e^(-t/t2)),

whose integrals are written out in `ExpSum`. Every expectation here comes from these
formulas (or from scipy root finding on them), never from the FMU's own output, except the
step-size invariance test, which compares the FMU with itself by design.
"""

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from conftest import PAPER, Driver, modal_weights, unlimited_step_response

#: Currents [A]: the FMU integrates in closed form, so only rounding separates it from the math.
CURRENT_ABS_TOL = 1e-9
#: Relative tolerance on algebraic outputs (voltage, power, h2Flow) and on the integrals.
REL_TOL = 1e-9

OUTPUTS = ("current", "voltage", "power", "h2Flow", "energy", "h2Produced")
SECONDS_PER_HOUR = 3600.0


def params(**overrides):
    """The paper's parameters with some replaced."""
    p = dict(PAPER)
    p.update(overrides)
    return p


def start(driver, setpoint, p=PAPER, start_time=0.0):
    """A driver initialised in steady state at `setpoint` with parameters `p`."""
    return driver().initialize(setpoint=setpoint, start_time=start_time, **p)


def elapsed_charge(d, p):
    """int_0^t I dt [A s], read back from h2Produced = c int I dt / 3600."""
    return d.get("h2Produced") * SECONDS_PER_HOUR / p["h2Coefficient"]


def assert_close(got, want, rel=REL_TOL, what=""):
    assert got == pytest.approx(want, rel=rel, abs=0.0), f"{what}: got {got!r}, want {want!r}"


def assert_current(got, want, what=""):
    assert abs(got - want) <= CURRENT_ABS_TOL, f"{what}: current {got!r} A, want {want!r} A (diff {got - want:.3e})"


class ExpSum:
    """x(t) = y + A e^(-t/t1) + B e^(-t/t2), with its exact integrals.

    Antiderivatives (t12 = t1 t2 / (t1 + t2)):
        int x dt   = y t - A t1 e^(-t/t1) - B t2 e^(-t/t2)
        int x^2 dt = y^2 t - 2 y A t1 e^(-t/t1) - 2 y B t2 e^(-t/t2)
                     - A^2 t1/2 e^(-2t/t1) - B^2 t2/2 e^(-2t/t2) - 2 A B t12 e^(-t/t12)
    """

    def __init__(self, y, amp1, amp2, tau1, tau2):
        self.y, self.amp1, self.amp2, self.tau1, self.tau2 = y, amp1, amp2, tau1, tau2

    @classmethod
    def step_response(cls, u0, u1, p=PAPER):
        """I_tf after a step u0 -> u1 from steady state: y = K u1, A = K (u0 - u1) a, B = K (u0 - u1) b."""
        a, b = modal_weights(p)
        k = p["gain"]
        return cls(k * u1, k * (u0 - u1) * a, k * (u0 - u1) * b, p["tauPole1"], p["tauPole2"])

    def __call__(self, t):
        return self.y + self.amp1 * math.exp(-t / self.tau1) + self.amp2 * math.exp(-t / self.tau2)

    def slope(self, t):
        return -self.amp1 / self.tau1 * math.exp(-t / self.tau1) - self.amp2 / self.tau2 * math.exp(-t / self.tau2)

    def _antiderivative(self, t):
        y, a, b, t1, t2 = self.y, self.amp1, self.amp2, self.tau1, self.tau2
        e1, e2 = math.exp(-t / t1), math.exp(-t / t2)
        return y * t - a * t1 * e1 - b * t2 * e2

    def _antiderivative_sq(self, t):
        y, a, b, t1, t2 = self.y, self.amp1, self.amp2, self.tau1, self.tau2
        t12 = t1 * t2 / (t1 + t2)
        e1, e2 = math.exp(-t / t1), math.exp(-t / t2)
        return (
            y * y * t
            - 2 * y * a * t1 * e1
            - 2 * y * b * t2 * e2
            - a * a * t1 / 2 * e1 * e1
            - b * b * t2 / 2 * e2 * e2
            - 2 * a * b * t12 * math.exp(-t / t12)
        )

    def integral(self, t0, t1):
        """int_{t0}^{t1} x dt."""
        return self._antiderivative(t1) - self._antiderivative(t0)

    def integral_sq(self, t0, t1):
        """int_{t0}^{t1} x^2 dt."""
        return self._antiderivative_sq(t1) - self._antiderivative_sq(t0)


def energy(p, charge, charge_sq):
    """E = int (V0 + R I) I dt = V0 int I dt + R int I^2 dt [J]."""
    return p["voltageIntercept"] * charge + p["ohmicResistance"] * charge_sq


def run_to(d, times, setpoint):
    """Steps the driver through the increasing elapsed `times` with `setpoint` held; yields the
    elapsed time as the driver (and the FMU) count it, a running sum of the step sizes."""
    t0 = d.time
    for t in times:
        d.step(t - (d.time - t0), setpoint=setpoint)
        yield d.time - t0


# --------------------------------------------------------------------------------------
# 1. Steady states
# --------------------------------------------------------------------------------------

NON_PAPER = params(gain=0.6, voltageIntercept=30.0, ohmicResistance=0.2, h2Coefficient=9.0)


@pytest.mark.parametrize("p", [PAPER, NON_PAPER], ids=["paper", "non-paper"])
@pytest.mark.parametrize("setpoint", [60.0, 75.0, 100.0])
def test_steady_state(driver, p, setpoint):
    """I = K u, V = V0 + R I, P = V I, F = c I at initialisation and after 3600 s of 1 s steps;
    then E = P 3600 s and N = c I 3600 s / 3600 s/h = c I."""
    current = p["gain"] * setpoint
    voltage = p["voltageIntercept"] + p["ohmicResistance"] * current
    power = voltage * current
    flow = p["h2Coefficient"] * current

    d = start(driver, setpoint, p)
    expected = dict(current=current, voltage=voltage, power=power, h2Flow=flow, energy=0.0, h2Produced=0.0)
    assert dict(zip(OUTPUTS, d.get(*OUTPUTS))) == pytest.approx(expected, rel=REL_TOL, abs=0.0)

    for _ in range(3600):
        d.step(1.0, setpoint=setpoint)
    expected.update(energy=power * 3600.0, h2Produced=flow)
    assert dict(zip(OUTPUTS, d.get(*OUTPUTS))) == pytest.approx(expected, rel=REL_TOL, abs=0.0)


def test_sanity_figures_at_full_load(driver):
    """Paper figures at 100 %: I = 53.4 A, V ~ 43.92 V, P ~ 2345 W, F ~ 513.6 Nl/h."""
    d = start(driver, 100.0)
    current, voltage, power, flow = d.get("current", "voltage", "power", "h2Flow")
    assert current == pytest.approx(53.4, rel=1e-12)
    assert voltage == pytest.approx(43.92, abs=0.01)
    assert power == pytest.approx(2345.0, abs=1.0)
    assert flow == pytest.approx(513.6, abs=0.1)


# --------------------------------------------------------------------------------------
# 2. Negative steps: falling current is not limited, so I = I_tf
# --------------------------------------------------------------------------------------

SAMPLE_TIMES = [0.1, 0.25, 0.5, 1.0, 2.0, 3.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 300.0, 500.0, 1000.0, 1500.0]

#: Other pole/zero placements: zero between the poles, zero at 0 (a < 0), zero beyond the slow
#: pole (b < 0: I_tf undershoots and recovers, slower than r for these steps).
OTHER_TAUS = {
    "zero-between": params(tauZero=30.0, tauPole1=10.0, tauPole2=60.0),
    "zero-at-0": params(tauZero=0.0, tauPole1=3.0, tauPole2=40.0),
    "zero-beyond": params(tauZero=150.0, tauPole1=2.0, tauPole2=100.0),
}

NEGATIVE_CASES = [
    pytest.param(u0, u1, PAPER, id=f"{u0:g}->{u1:g}-paper") for u0, u1 in [(100, 60), (100, 90), (85, 65), (70, 60)]
] + [
    pytest.param(u0, u1, p, id=f"{u0:g}->{u1:g}-{name}")
    for name, p in OTHER_TAUS.items()
    for u0, u1 in [(100, 60), (85, 65)]
]


def max_rise_rate(response, horizon=2000.0):
    """Largest slope of I_tf on a fine grid (a precondition check, not an expectation)."""
    grid = np.concatenate([np.linspace(0.0, 20.0, 4001), np.linspace(20.0, horizon, 4001)])
    return max(response.slope(t) for t in grid)


@pytest.mark.parametrize("u0, u1, p", NEGATIVE_CASES)
def test_negative_step_follows_unlimited_response(driver, u0, u1, p):
    """u0 -> u1 < u0: I(t) = K u1 + K (u0 - u1)(a e^(-t/t1) + b e^(-t/t2)) (no rate limit binds),
    E(t) = V0 int_0^t I + R int_0^t I^2 and N(t) = c int_0^t I / 3600 from the antiderivatives."""
    response = ExpSum.step_response(u0, u1, p)
    assert max_rise_rate(response) < p["rampUpLimit"], "precondition: the rate limit must never bind"

    d = start(driver, u0, p)
    for t in run_to(d, SAMPLE_TIMES, u1):
        assert_current(d.get("current"), unlimited_step_response(u0, u1, t, p), f"t = {t} s")
        charge = response.integral(0.0, t)
        assert_close(d.get("energy"), energy(p, charge, response.integral_sq(0.0, t)), what=f"energy at {t} s")
        assert_close(elapsed_charge(d, p), charge, what=f"charge at {t} s")


# --------------------------------------------------------------------------------------
# 3. Positive steps: ramp at r from K u0 until the line meets I_tf
# --------------------------------------------------------------------------------------


def initial_rise_rate(u0, u1, p):
    """I_tf'(0+) = K (u1 - u0) tz / (t1 t2)."""
    return p["gain"] * (u1 - u0) * p["tauZero"] / (p["tauPole1"] * p["tauPole2"])


def meeting_time(u0, u1, p):
    """t* > 0 with K u0 + r t* = I_tf(t*), or None when I_tf'(0+) <= r (the limit never binds).

    With a, b >= 0, I_tf is concave after a positive step, so I_tf(t) - (K u0 + r t) rises
    while I_tf' > r, peaks where I_tf' = r, and then falls through zero once, before the
    line reaches K u1 at t = K (u1 - u0) / r.
    """
    r = p["rampUpLimit"]
    if initial_rise_rate(u0, u1, p) <= r:
        return None
    response = ExpSum.step_response(u0, u1, p)
    gap = lambda t: response(t) - (p["gain"] * u0 + r * t)  # noqa: E731
    peak = brentq(lambda t: response.slope(t) - r, 0.0, 100.0 * p["tauPole2"], xtol=1e-15, rtol=1e-15)
    return brentq(gap, peak, p["gain"] * (u1 - u0) / r, xtol=1e-15, rtol=1e-15)


def positive_step_expectation(u0, u1, p, t):
    """Expected current and charge int_0^t I at elapsed time t after u0 -> u1 > u0:

        t < t*:  I = K u0 + r t,   Q = K u0 t + r t^2 / 2,       Q2 = ((K u0 + r t)^3 - (K u0)^3) / (3 r)
        t >= t*: I = I_tf(t),      Q = Q(t*) + int_{t*}^t I_tf,  Q2 = Q2(t*) + int_{t*}^t I_tf^2
    (without a ramp, t* = 0). Returns (I, Q, Q2) with Q2 = int_0^t I^2 dt.
    """
    k, r = p["gain"], p["rampUpLimit"]
    i0 = k * u0
    response = ExpSum.step_response(u0, u1, p)
    t_meet = meeting_time(u0, u1, p) or 0.0

    def ramp(t):
        return i0 + r * t, i0 * t + r * t * t / 2, ((i0 + r * t) ** 3 - i0**3) / (3 * r)

    if t < t_meet:
        return ramp(t)
    _, q, q2 = ramp(t_meet)
    return response(t), q + response.integral(t_meet, t), q2 + response.integral_sq(t_meet, t)


POSITIVE_CASES = [
    pytest.param(60, 100, PAPER, id="60->100"),
    pytest.param(60, 65, PAPER, id="60->65"),
    pytest.param(80, 90, PAPER, id="80->90"),
    pytest.param(90, 100, PAPER, id="90->100"),
    pytest.param(60, 100, params(rampUpLimit=0.5), id="60->100-r0.5"),
    pytest.param(80, 90, params(rampUpLimit=0.5), id="80->90-r0.5"),
    pytest.param(60, 100, params(rampUpLimit=0.1), id="60->100-r0.1"),
    pytest.param(60, 65, params(rampUpLimit=0.1), id="60->65-r0.1"),
    pytest.param(60, 100, OTHER_TAUS["zero-between"], id="60->100-zero-between"),
    # I_tf'(0+) <= r: no ramp at all.
    pytest.param(80, 80.5, PAPER, id="80->80.5-no-ramp"),
    pytest.param(90, 100, params(rampUpLimit=2.5), id="90->100-r2.5-no-ramp"),
]


@pytest.mark.parametrize("u0, u1, p", POSITIVE_CASES)
def test_positive_step_ramps_then_tracks(driver, u0, u1, p):
    """u0 -> u1 > u0: I = K u0 + r t before t*, I = I_tf(t) after (t* from brentq), also just
    around t*; the charge Q = int I dt (from h2Produced) and the energy V0 Q + R int I^2 dt
    follow the same piecewise closed form."""
    a, b = modal_weights(p)
    assert a >= 0 and b >= 0, "precondition: the concavity argument of meeting_time needs a, b >= 0"
    t_meet = meeting_time(u0, u1, p)
    ramps = initial_rise_rate(u0, u1, p) > p["rampUpLimit"]
    assert (t_meet is not None) == ramps

    times = set(SAMPLE_TIMES)
    if t_meet is not None:
        assert 0 < t_meet < 1500
        times |= {t_meet + dt for dt in (-1.0, -1e-3, -1e-6, 1e-6, 1e-3, 1.0)}
    times = sorted(t for t in times if t > 0)

    def check(d, t, how):
        current, charge, charge_sq = positive_step_expectation(u0, u1, p, t)
        what = f"{how}, t = {t} s ({'ramp' if t_meet is not None and t < t_meet else 'tracking'}, t* = {t_meet})"
        assert_current(d.get("current"), current, what)
        assert_close(elapsed_charge(d, p), charge, what=f"charge, {what}")
        assert_close(d.get("energy"), energy(p, charge, charge_sq), what=f"energy, {what}")

    d = start(driver, u0, p)
    for t in run_to(d, times, u1):
        check(d, t, "stepping through the sample times")

    # One step from the setpoint change over the meeting instant (or far beyond it).
    for t in [t for t in times if abs(t - (t_meet or 0.0)) <= 1e-3] + [1500.0]:
        single = start(driver, u0, p)
        single.step(t, setpoint=u1)
        check(single, t, "one step")


def test_ramp_charge_is_exact(driver):
    """Over the ramp of 60 -> 100 (t* ~ 89.9 s), one step of t: Q = K u0 t + r t^2 / 2."""
    p = PAPER
    t_meet = meeting_time(60, 100, p)
    for t in (0.5, 10.0, 0.99 * t_meet):
        d = start(driver, 60.0, p)
        d.step(t, setpoint=100.0)
        assert_close(elapsed_charge(d, p), p["gain"] * 60.0 * t + p["rampUpLimit"] * t * t / 2, what=f"t = {t}")
        assert_current(d.get("current"), p["gain"] * 60.0 + p["rampUpLimit"] * t, f"t = {t}")


# --------------------------------------------------------------------------------------
# 4. Step-size invariance and arbitrary schedules
# --------------------------------------------------------------------------------------

BLOCK = 60.0  #: the schedule changes only at multiples of BLOCK seconds
#: (time of change [s], setpoint [%]), starting from steady state at the first entry.
SCHEDULE = [(0.0, 80.0), (60.0, 100.0), (300.0, 60.0), (600.0, 85.0), (660.0, 65.0), (1200.0, 100.0)]
END = 1800.0
#: h = 0.001 s costs ~3 FMU calls per step: run it over the first blocks only (180 s).
FINE_BLOCKS = 3


def setpoint_at(t, schedule=SCHEDULE):
    return [u for t_change, u in schedule if t_change <= t][-1]


def run_blocks(d, n_blocks, steps_for_block):
    """Drives the schedule block by block with the step sizes `steps_for_block(i)` (summing to
    BLOCK); returns the outputs (current, energy, h2Produced) at the end of each block."""
    out = []
    for i in range(n_blocks):
        u = setpoint_at(i * BLOCK)
        for h in steps_for_block(i):
            d.step(h, setpoint=u)
        out.append(d.get("current", "energy", "h2Produced"))
    return out


def fixed_steps(h):
    n = round(BLOCK / h)
    assert n * h == pytest.approx(BLOCK, rel=1e-15)
    return lambda i: [h] * n


def random_steps(seed):
    """Random partitions of each block: 1..25 steps, some of them tiny."""
    rng = np.random.default_rng(seed)

    def steps(i):
        cuts = rng.uniform(0.0, BLOCK, size=rng.integers(0, 25))
        if rng.random() < 0.3:
            cuts = np.append(cuts, [1e-7, BLOCK - 1e-7])
        points = np.unique(np.concatenate([[0.0], cuts, [BLOCK]]))
        return [float(h) for h in np.diff(points)]

    return steps


@pytest.fixture(scope="module")
def block_runs(unzipdir, model_description):
    """The schedule driven with several step sizes (h = 0.001 s only for the first 3 blocks)."""
    runs = {}
    for label, steps, n_blocks in [
        ("h=60", fixed_steps(60.0), int(END / BLOCK)),
        ("h=7.5", fixed_steps(7.5), int(END / BLOCK)),
        ("h=1", fixed_steps(1.0), int(END / BLOCK)),
        ("h=0.1", fixed_steps(0.1), int(END / BLOCK)),
        ("h=0.001", fixed_steps(0.001), FINE_BLOCKS),
        ("random-1", random_steps(1), int(END / BLOCK)),
        ("random-2", random_steps(2), int(END / BLOCK)),
    ]:
        d = Driver(unzipdir, model_description).initialize(setpoint=SCHEDULE[0][1], **PAPER)
        runs[label] = run_blocks(d, n_blocks, steps)
        d.free()
    return runs


@pytest.mark.parametrize("label", ["h=7.5", "h=1", "h=0.1", "h=0.001", "random-1", "random-2"])
def test_results_do_not_depend_on_step_size(block_runs, label):
    """At every block end: |I_h - I_60| <= 1e-9 A; E and N agree to 1e-9 relative."""
    reference = block_runs["h=60"]
    assert len(block_runs[label]) == (FINE_BLOCKS if label == "h=0.001" else len(reference))
    for i, (got, want) in enumerate(zip(block_runs[label], reference)):
        t = (i + 1) * BLOCK
        assert_current(got[0], want[0], f"{label}, t = {t} s")
        assert_close(got[1], want[1], what=f"{label}: energy at {t} s")
        assert_close(got[2], want[2], what=f"{label}: h2Produced at {t} s")


class ScheduleReference:
    """Exact current for a piecewise-constant setpoint schedule (inside the window) from steady state.

    By superposition, I_tf(t) = K u_0 + sum_{t_j <= t} K (u_j - u_{j-1})(1 - a e^(-(t-t_j)/t1) - b e^(-(t-t_j)/t2)).
    With g(s) = I_tf(s) - r s and I(0) = I_tf(0), the rate limit gives I(t) = r t + min_{[0,t]} g.
    The minimum lies at 0, at a change time, at t, or at an interior minimum of g (g' = 0).
    On a segment I_tf' = A e^(-s/t1) + B e^(-s/t2) has at most one extremum (where g'' = 0),
    so g' is monotone between it and the segment ends: each part holds at most one root.
    """

    def __init__(self, schedule, p=PAPER):
        self.k, self.r = p["gain"], p["rampUpLimit"]
        self.a, self.b = modal_weights(p)
        self.t1, self.t2 = p["tauPole1"], p["tauPole2"]
        self.u0 = schedule[0][1]
        self.changes = [(t, u - schedule[i][1]) for i, (t, u) in enumerate(schedule[1:])]
        self.candidates = [0.0] + [t for t, _ in self.changes]
        bounds = [t for t, _ in self.changes] + [math.inf]
        for lo, hi in zip([0.0] + bounds[:-1], bounds):
            # Beyond 50 time constants I_tf' is ~0 < r: g only falls, no more interior minima.
            self.candidates += self._interior_minima(lo, min(hi, lo + 50 * max(self.t1, self.t2)))

    def unlimited(self, t):
        total = self.k * self.u0
        for tj, du in self.changes:
            if tj <= t:
                dt = t - tj
                total += self.k * du * (1 - self.a * math.exp(-dt / self.t1) - self.b * math.exp(-dt / self.t2))
        return total

    def _derivative(self, s, order, segment_start):
        """d^order I_tf/ds^order (order 1 or 2) at s, with the changes up to `segment_start`:
        each contributes K du (a/t1^n e^(-(s-tj)/t1) + b/t2^n e^(-(s-tj)/t2)), sign (-1)^(n+1)."""
        total = 0.0
        for tj, du in self.changes:
            if tj <= segment_start:
                w1 = self.a / self.t1**order * math.exp(-(s - tj) / self.t1)
                w2 = self.b / self.t2**order * math.exp(-(s - tj) / self.t2)
                total += (-1) ** (order + 1) * self.k * du * (w1 + w2)
        return total

    def g(self, s):
        return self.unlimited(s) - self.r * s

    def _interior_minima(self, lo, hi):
        """Roots of g' = I_tf' - r on the segment (lo, hi) where g' turns from negative to positive."""
        g1 = lambda s: self._derivative(s, 1, lo) - self.r  # noqa: E731
        g2 = lambda s: self._derivative(s, 2, lo)  # noqa: E731
        points = [lo, hi]
        if g2(lo) * g2(hi) < 0:
            points.insert(1, brentq(g2, lo, hi, xtol=1e-13))
        minima = []
        for p, q in zip(points, points[1:]):
            if g1(p) < 0 < g1(q):
                minima.append(brentq(g1, p, q, xtol=1e-13))
        return minima

    def current(self, t):
        """I(t) = r t + min of g over the candidates in [0, t] and t itself."""
        return self.r * t + min([self.g(s) for s in self.candidates if s <= t] + [self.g(t)])


def test_schedule_follows_closed_form(block_runs):
    """The block-end currents of the 60 s run equal the exact rate-limited response (this ties
    the invariance test to the math, not only to itself)."""
    reference = ScheduleReference(SCHEDULE)
    for i, (current, _, _) in enumerate(block_runs["h=60"]):
        t = (i + 1) * BLOCK
        assert_current(current, reference.current(t), f"t = {t} s")


SCHEDULE_CASES = {
    # ramp cut short by a fall, then ramp again from below; ramp ending inside a step
    "paper": (PAPER, [(0.0, 60.0), (30.0, 100.0), (40.0, 70.0), (100.0, 95.0), (160.0, 62.0), (170.0, 100.0)]),
    # zero beyond the slow pole: after a fall I_tf undershoots and recovers faster than r
    "zero-beyond": (
        params(tauZero=200.0, tauPole1=2.0, tauPole2=100.0, rampUpLimit=0.05),
        [(0.0, 100.0), (5.0, 60.0), (400.0, 100.0), (410.0, 80.0)],
    ),
    # zero at 0: a rise first lags, then overtakes r
    "zero-at-0": (params(tauZero=0.0, tauPole1=3.0, tauPole2=40.0), [(0.0, 60.0), (10.0, 100.0), (200.0, 60.0)]),
}


@pytest.mark.parametrize("case", list(SCHEDULE_CASES))
def test_arbitrary_schedule_matches_closed_form(driver, case):
    """I(t) = r t + min_{[0,t]} (I_tf(s) - r s) every 0.5 s over 600 s, for schedules that cut
    ramps short and for non-monotone I_tf (see ScheduleReference)."""
    p, schedule = SCHEDULE_CASES[case]
    reference = ScheduleReference(schedule, p)
    d = start(driver, schedule[0][1], p)
    h = 0.5
    for n in range(1, 1201):
        d.step(h, setpoint=setpoint_at((n - 1) * h, schedule))
        assert_current(d.get("current"), reference.current(n * h), f"{case}: t = {n * h} s")


# --------------------------------------------------------------------------------------
# 5. Setpoint clamping
# --------------------------------------------------------------------------------------


def outside_warnings(d):
    return [m for status, _, m in d.messages if status == "WARNING" and "outside" in m]


NARROW_WINDOW = params(minSetpoint=40.0, maxSetpoint=90.0)


@pytest.mark.parametrize(
    "outside, inside, p",
    [(120.0, 100.0, PAPER), (30.0, 60.0, PAPER), (95.0, 90.0, NARROW_WINDOW), (20.0, 40.0, NARROW_WINDOW)],
    ids=["above", "below", "above-narrow-window", "below-narrow-window"],
)
def test_clamped_setpoint_behaves_like_the_limit(driver, outside, inside, p):
    """u outside [minSetpoint, maxSetpoint] gives bit-for-bit the outputs of clamp(u), from
    initialisation on, also after a step into the window and back out."""
    clamped, reference = start(driver, outside, p), start(driver, inside, p)
    assert clamped.get(*OUTPUTS) == reference.get(*OUTPUTS)
    plan = [(outside, inside)] * 20 + [(80.0, 80.0)] * 20 + [(outside, inside)] * 200
    for n, (u_clamped, u_ref) in enumerate(plan):
        clamped.step(0.75, setpoint=u_clamped)
        reference.step(0.75, setpoint=u_ref)
        assert clamped.get(*OUTPUTS) == reference.get(*OUTPUTS), f"step {n}"


def test_clamping_warns_once_per_excursion(driver):
    """One warning when the setpoint leaves the window, none while it stays out or on the
    limits, and a new one for each later excursion."""
    d = start(driver, 120.0)
    assert len(outside_warnings(d)) == 1, "excursion at initialisation"
    plan = [(120.0, 1), (150.0, 1), (90.0, 1), (100.0, 1), (60.0, 1), (30.0, 2), (10.0, 2), (75.0, 2), (101.0, 3)]
    for u, expected in plan:
        for _ in range(5):
            d.step(1.0, setpoint=u)
        assert len(outside_warnings(d)) == expected, f"after setpoint {u}: {outside_warnings(d)}"

    inside = start(driver, 100.0)
    for u in (60.0, 100.0, 80.0):
        inside.step(1.0, setpoint=u)
    assert outside_warnings(inside) == []


# --------------------------------------------------------------------------------------
# 6. Start time
# --------------------------------------------------------------------------------------


def test_start_time_does_not_change_the_response(driver):
    """setupExperiment(startTime = 1000 s) gives the same outputs as a start at 0 at equal
    elapsed times (currents to 1e-9 A, integrals to 1e-9 relative), and both follow the
    closed form of the 60 -> 100 step."""
    from_zero, from_1000 = start(driver, 60.0), start(driver, 60.0, start_time=1000.0)
    steps = [0.5] * 40 + [3.0] * 20 + [10.0] * 50
    elapsed = 0.0
    for n, h in enumerate(steps):
        u = 100.0 if n < 100 else 70.0
        from_zero.step(h, setpoint=u)
        from_1000.step(h, setpoint=u)
        elapsed += h
        a, b = from_zero.get(*OUTPUTS), from_1000.get(*OUTPUTS)
        assert_current(b[0], a[0], f"elapsed {elapsed} s")
        assert_close(b[4], a[4], what=f"energy at {elapsed} s")
        assert_close(b[5], a[5], what=f"h2Produced at {elapsed} s")
        if n < 100:
            assert_current(b[0], positive_step_expectation(60, 100, PAPER, elapsed)[0], f"elapsed {elapsed} s")
    assert from_1000.time == pytest.approx(1000.0 + elapsed, rel=1e-15)
