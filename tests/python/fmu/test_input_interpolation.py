"""Interpolated inputs (canInterpolateInputs, fmi2SetRealInputDerivatives) through fmpy.

A master that sets the setpoint and its first derivative at each communication point gets
the exact response to the piecewise-linear setpoint, so it can take large steps. The
reference is a second instance stepped at 1 ms with the setpoint at each short step's
midpoint, independent of the FMU's interpolation code.
"""

from ctypes import c_double, c_int, c_uint

import pytest

FINE_STEP = 0.001
#: Agreement with the fine-step reference [A]. The reference's own error is a ripple from its
#: piecewise-constant input (amplitude K·|du/dt|·FINE_STEP/2 seen through G's high-frequency
#: gain K·τz/(τp1·τp2)/s): about 3e-7 A here.
REFERENCE_TOLERANCE = 1e-6
#: Agreement between two exact runs with different step sizes [A].
EXACT_TOLERANCE = 1e-9


def ramp_profile(t):
    """Setpoint [%] and its slope [%/s]: up across the rate limit, a plateau, down through the
    lower edge of the window (clamped below 60 %), and back up. Kinks only at multiples of 30 s,
    which are communication points of every run."""
    pieces = [(0.0, 70.0, 0.8), (30.0, 94.0, 0.0), (60.0, 94.0, -0.8), (120.0, 46.0, 1.0), (150.0, 76.0, 0.0)]
    for start, value, slope in reversed(pieces):
        if t >= start - 1e-12:
            return value + slope * (t - start), slope
    raise ValueError(t)


def run_interpolated(driver, step, horizon=180.0):
    d = driver()
    d.initialize(setpoint=ramp_profile(0.0)[0])
    vr = d.vr["setpoint"]
    out = {}
    n = int(round(horizon / step))
    for k in range(n):
        t = k * step
        u, slope = ramp_profile(t)
        d.set(setpoint=u)
        d.fmu.setRealInputDerivatives([vr], [1], [slope])
        d.step(step)
        out[round((k + 1) * step, 6)] = d.get("current", "energy")
    return out


def run_fine(driver, horizon=180.0):
    d = driver()
    d.initialize(setpoint=ramp_profile(0.0)[0])
    out = {}
    n = int(round(horizon / FINE_STEP))
    for k in range(n):
        u, _ = ramp_profile((k + 0.5) * FINE_STEP)
        d.step(FINE_STEP, setpoint=u)
        out[round((k + 1) * FINE_STEP, 6)] = d.get("current", "energy")
    return out


@pytest.fixture(scope="module")
def fine(unzipdir, model_description):
    from conftest import Driver

    made = []

    def make():
        d = Driver(unzipdir, model_description)
        made.append(d)
        return d

    result = run_fine(make)
    for d in made:
        d.free()
    return result


@pytest.mark.parametrize("step", [10.0, 30.0])
def test_large_interpolated_steps_match_the_fine_reference(driver, fine, step):
    coarse = run_interpolated(driver, step)
    for t, (current, energy) in coarse.items():
        ref_current, ref_energy = fine[t]
        assert abs(current - ref_current) < REFERENCE_TOLERANCE, f"t={t}: {current} vs {ref_current}"
        assert abs(energy - ref_energy) < 1e-7 * ref_energy, f"t={t}: energy {energy} vs {ref_energy}"


def test_interpolated_steps_do_not_depend_on_the_step_size(driver):
    small = run_interpolated(driver, 2.0)
    large = run_interpolated(driver, 30.0)
    for t, (current, energy) in large.items():
        assert abs(current - small[t][0]) < EXACT_TOLERANCE, f"t={t}"
        assert abs(energy - small[t][1]) < 1e-10 * energy


def test_derivative_applies_to_the_next_step_only(driver):
    """After a step the derivative is back to zero: without a new one the input is held at the
    value the master set (it is not extrapolated)."""
    silent, explicit, repeated = driver(), driver(), driver()
    for d in (silent, explicit, repeated):
        d.initialize(setpoint=70.0)
        d.fmu.setRealInputDerivatives([d.vr["setpoint"]], [1], [1.0])
        d.step(5.0)
    explicit.fmu.setRealInputDerivatives([explicit.vr["setpoint"]], [1], [0.0])
    repeated.fmu.setRealInputDerivatives([repeated.vr["setpoint"]], [1], [1.0])
    for d in (silent, explicit, repeated):
        d.step(20.0)
    assert silent.get("setpoint") == 70.0
    assert silent.get("current", "energy") == explicit.get("current", "energy")
    assert silent.get("current") != repeated.get("current")


def test_derivative_and_value_may_be_set_in_either_order(driver):
    """The standard does not order fmi2SetReal and fmi2SetRealInputDerivatives within a
    communication point: both orders give the same step."""
    value_first, derivative_first = driver(), driver()
    for d in (value_first, derivative_first):
        d.initialize(setpoint=80.0)
    vr = value_first.vr["setpoint"]
    value_first.set(setpoint=70.0)
    value_first.fmu.setRealInputDerivatives([vr], [1], [2.0])
    derivative_first.fmu.setRealInputDerivatives([vr], [1], [2.0])
    derivative_first.set(setpoint=70.0)
    for d in (value_first, derivative_first):
        d.step(10.0)
    assert value_first.get("current", "energy") == derivative_first.get("current", "energy")


def test_higher_derivatives_are_ignored_with_a_warning(driver):
    d, plain = driver(), driver()
    for x in (d, plain):
        x.initialize(setpoint=80.0)
    status = d.fmu.fmi2SetRealInputDerivatives(
        d.fmu.component, (c_uint * 1)(d.vr["setpoint"]), 1, (c_int * 1)(2), (c_double * 1)(0.5)
    )
    assert status == 1  # fmi2Warning
    assert any(label == "WARNING" and "order 2" in text for label, _, text in d.messages)
    d.step(10.0)
    plain.step(10.0)
    assert d.get("current") == plain.get("current")
