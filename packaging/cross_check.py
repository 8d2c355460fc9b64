#!/usr/bin/env python3
"""Write the packaged FMU into the layout of the FMI cross-check repository.

    .venv/bin/python packaging/cross_check.py [--out target/cross-check]

For every platform whose binary the FMU holds (linux64, win64):

    <out>/fmus/2.0/cs/<platform>/aem-electrolyser-fmu/<version>/AemElectrolyser/
        AemElectrolyser.fmu        the packaged FMU
        AemElectrolyser_in.csv     the setpoint [%]: 90 % for 10 s, 65 % until 700 s, then 100 %
        AemElectrolyser_ref.csv    current [A], voltage [V], power [W], h2Flow [Nl/h],
                                   energy [J], h2Produced [Nl] every second, from the closed form
        AemElectrolyser_ref.opt    start, stop, step size, relative tolerance
        ReadMe.txt                 what the reference is and how it was made

The reference comes from the paper's model in closed form, not from the FMU: steady state
I = K*u; after the falling step (never rate-limited)
    I(s) = K*u1 + K*(u0 - u1)*(a*exp(-s/tp1) + b*exp(-s/tp2)),  a = (tz - tp1)/(tp2 - tp1), b = 1 - a;
after the rising step the current ramps at exactly rampUpLimit r while the limit binds (the
unlimited response would rise at up to K*(u1-u0)*(a/tp1 + b/tp2) ~ 8 A/s), which it does for
about 78 s, past the stop time of 760 s. V = V0 + R*I, P = V*I, F = c*I; energy and hydrogen
are the exact integrals of P and F/3600.

`python -m fmpy.cross_check --fmus_dir <out>/fmus --include linux64 --simulate --result_dir
<out>/results` then imports the FMU with fmpy and compares against the reference, and
`python -m fmpy.cross_check.validate_vendor_repo <out>` checks the whole tree.
Standard library and aem_electrolyser.cli only (the FMU's start values are read from its model
description).
"""

import argparse
import math
import shutil
import sys
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path
from aem_electrolyser.cli import add_fmu_option, quiet_on_closed_stdout, resolve_fmu, writable_folder

ROOT = Path(__file__).resolve().parent.parent
MODEL = "AemElectrolyser"
TOOL = "aem-electrolyser-fmu"
START, STOP, STEP = 0.0, 760.0, 1.0
#: The input schedule: (time [s], setpoint [%]) from which the setpoint holds.
SCHEDULE = [(0.0, 90.0), (10.0, 65.0), (700.0, 100.0)]
OUTPUTS = ("current", "voltage", "power", "h2Flow", "energy", "h2Produced")
PLATFORMS = {"linux64": ".so", "win64": ".dll"}


def crate_version():
    """The workspace's version (the cross-check tree's tool version)."""
    in_workspace_package = False
    for line in (ROOT / "Cargo.toml").read_text(encoding="utf-8").splitlines():
        if line.strip().startswith("["):
            in_workspace_package = line.strip() == "[workspace.package]"
        elif in_workspace_package and line.split("=")[0].strip() == "version":
            return line.split("=", 1)[1].strip().strip('"')
    sys.exit("cross_check.py: no version in [workspace.package] of Cargo.toml")


def start_values(fmu):
    """{name: start} of the FMU's Real parameters, from its model description."""
    with zipfile.ZipFile(fmu) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    values = {}
    for var in root.iter("ScalarVariable"):
        real = var.find("Real")
        if var.get("causality") == "parameter" and real is not None and real.get("start") is not None:
            values[var.get("name")] = float(real.get("start"))
    return values


class ClosedForm:
    """The paper's module along SCHEDULE, exactly."""

    def __init__(self, p):
        self.k, self.r = p["gain"], p["rampUpLimit"]
        self.tp1, self.tp2 = p["tauPole1"], p["tauPole2"]
        self.a = (p["tauZero"] - self.tp1) / (self.tp2 - self.tp1)
        self.b = 1.0 - self.a
        self.v0, self.ohm, self.c = p["voltageIntercept"], p["ohmicResistance"], p["h2Coefficient"]
        (_, self.u0), (self.t1, self.u1), (self.t2, self.u2) = SCHEDULE
        self.i0 = self.k * self.u0
        self.i_ramp_start = self.falling(self.t2)
        # The ramp must bind until the stop time: check the unlimited response's slope there.
        d = self.k * (self.u2 - self.u1)
        assert self.i_ramp_start + self.r * (STOP - self.t2) < self.k * self.u2, "the ramp must bind up to STOP"
        assert d * (self.a / self.tp1 + self.b / self.tp2) > self.r, "the step must be rate-limited"

    def falling(self, t):
        """Current [A] at t in [t1, t2] after the step u0 -> u1 at t1."""
        s = t - self.t1
        return self.k * self.u1 + self.k * (self.u0 - self.u1) * (
            self.a * math.exp(-s / self.tp1) + self.b * math.exp(-s / self.tp2)
        )

    def current(self, t):
        if t <= self.t1:
            return self.i0
        if t <= self.t2:
            return self.falling(t)
        return self.i_ramp_start + self.r * (t - self.t2)

    def integrals(self, t):
        """(∫I dt [A·s], ∫I² dt [A²·s]) from START to t."""
        q = self.i0 * min(t, self.t1)
        q2 = self.i0**2 * min(t, self.t1)
        if t > self.t1:
            s = min(t, self.t2) - self.t1
            y, amp1, amp2 = (
                self.k * self.u1,
                self.k * (self.u0 - self.u1) * self.a,
                self.k * (self.u0 - self.u1) * self.b,
            )
            g1, g2 = -math.expm1(-s / self.tp1), -math.expm1(-s / self.tp2)
            tau12 = self.tp1 * self.tp2 / (self.tp1 + self.tp2)
            q += y * s + amp1 * self.tp1 * g1 + amp2 * self.tp2 * g2
            q2 += (
                y * y * s
                + 2 * y * (amp1 * self.tp1 * g1 + amp2 * self.tp2 * g2)
                + amp1**2 * self.tp1 / 2 * -math.expm1(-2 * s / self.tp1)
                + amp2**2 * self.tp2 / 2 * -math.expm1(-2 * s / self.tp2)
                + 2 * amp1 * amp2 * tau12 * -math.expm1(-s / tau12)
            )
        if t > self.t2:
            s, i = t - self.t2, self.i_ramp_start
            q += i * s + self.r * s * s / 2
            q2 += i * i * s + i * self.r * s * s + self.r**2 * s**3 / 3
        return q, q2

    def outputs(self, t):
        i = self.current(t)
        v = self.v0 + self.ohm * i
        q, q2 = self.integrals(t)
        return i, v, v * i, self.c * i, self.v0 * q + self.ohm * q2, self.c * q / 3600.0


def write_model_folder(folder, fmu, reference):
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(fmu, folder / f"{MODEL}.fmu")
    rows = ['"time","setpoint"']
    for k, (t, u) in enumerate(SCHEDULE):
        if k > 0:  # a step: the old value up to t, the new one from t (same time twice)
            rows.append(f"{t!r},{SCHEDULE[k - 1][1]!r}")
        rows.append(f"{t!r},{u!r}")
    rows.append(f"{STOP!r},{SCHEDULE[-1][1]!r}")
    (folder / f"{MODEL}_in.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
    header = ",".join(f'"{name}"' for name in ("time", *OUTPUTS))
    lines = [header] + [",".join(repr(x) for x in row) for row in reference]
    (folder / f"{MODEL}_ref.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
    (folder / f"{MODEL}_ref.opt").write_text(
        f"StartTime,{START!r}\nStopTime,{STOP!r}\nStepSize,{STEP!r}\nRelTol,1e-06\n", encoding="utf-8"
    )
    (folder / "ReadMe.txt").write_text(
        "AEM electrolyser module (Omtveit et al., ISGT 2026) as an FMI 2.0 co-simulation FMU.\n"
        "Input: setpoint [%] 90 % until 10 s, 65 % until 700 s, then 100 % (a falling step, which\n"
        "follows the two poles, then a rising step held by the ramp limit of 0.22 A/s).\n"
        "The reference is the paper's model in closed form (step response of\n"
        "K(tz s + 1)/((tp1 s + 1)(tp2 s + 1)) and the ramp; exact integrals for energy and hydrogen),\n"
        "computed by packaging/cross_check.py of the aem-electrolyser-fmu repository, not by the FMU.\n"
        "The FMU integrates exactly: any step size that lands on 10 s and 700 s gives the same values.\n",
        encoding="utf-8",
    )


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_fmu_option(parser)
    parser.add_argument("--out", type=Path, default=ROOT / "target" / "cross-check")
    args = parser.parse_args(argv)
    writable_folder(args.out)
    args.fmu = resolve_fmu(parser, args)
    with zipfile.ZipFile(args.fmu) as z:
        names = set(z.namelist())
    platforms = [p for p, ext in PLATFORMS.items() if f"binaries/{p}/{MODEL}{ext}" in names]
    if not platforms:
        sys.exit(f"cross_check.py: {args.fmu} holds no linux64 or win64 binary")
    model = ClosedForm(start_values(args.fmu))
    n = round((STOP - START) / STEP)
    reference = [(START + k * STEP, *model.outputs(START + k * STEP)) for k in range(n + 1)]
    shutil.rmtree(args.out / "fmus", ignore_errors=True)
    folders = [args.out / "fmus" / "2.0" / "cs" / platform / TOOL / crate_version() / MODEL for platform in platforms]
    for folder in folders:
        write_model_folder(folder, args.fmu, reference)
    for folder in folders:
        print(f"wrote {folder}")


if __name__ == "__main__":
    quiet_on_closed_stdout(main)
