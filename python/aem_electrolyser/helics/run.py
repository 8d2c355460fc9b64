#!/usr/bin/env python3
"""Runs the HELICS federation (broker, wind, hub and grid federates, four processes over zmq on
127.0.0.1) through helics-cli, with every result in one folder.

    python -m aem_electrolyser.helics.run [--duration 3600] [--out out/helics] [--modules 25000]
                                          [--dispatch equal|sequential] [--seed 1] [--port 23404]
                                          [--wall-limit 1800] [--stall-timeout 30] [--fail-at T]
                                          [--fmu PATH] [--quiet] [--debug]

Writes <out>/federation.json, the packaged runner file (aem_electrolyser/helics/federation.json)
with these values, a fresh broker key and the folder itself as every federate's working folder
and --out, and runs `helics run --path=<out>/federation.json --no-kill-on-error`. Into <out>
go the records (<name>_published.csv, <name>_received.csv), the logs (<name>.log, runner.log for
helics-cli's own lines), summary.json and helics.png (wind and hub power, the exchange at the
bus and the slack's change, the bus voltage, hydrogen); the same file names of an earlier run
there are replaced. Run the folder's federation.json again with `helics run` to repeat the run.

A bar shows the simulated seconds the grid, the last federate of every step, has recorded. A
federate that fails ends the command with one line naming it and the reason from its log (exit
status 1); a bad argument is refused before anything starts (exit status 2).
"""

import argparse
import json
import os
import re
import shlex
import signal
import socket
import subprocess
import sys
import time
import uuid
from pathlib import Path

import numpy as np

from aem_electrolyser import cli
from aem_electrolyser.hub.dispatch import DISPATCHES, N_MODULES
from aem_electrolyser.extras import require
from aem_electrolyser.helics.records import read

#: The runner file that ships with the package: the template of every run; nothing is written beside it.
TEMPLATE = Path(__file__).resolve().parent / "federation.json"
FEDERATES = ("wind", "hub", "grid")
DEFAULT_PORT = 23404
PORTS = 12  # the broker's port and the next one, the zmq cores' from the broker's port + 5 on
BROKER_GRACE = 30.0  # s the broker outlives the federates' wall-clock limit (their messages come first)
BACKSTOP = 90.0  # s after the wall-clock limit the runner and everything it started are killed
POLL = 0.2  # s between looks at the records
#: the names of a run's files in its folder (removed before a run, so that none is a stale one)
RESULTS = (
    "federation.json",
    "runner.log",
    "summary.json",
    "helics.png",
    *(f"{n}.log" for n in ("broker", *FEDERATES)),
    *(f"{n}_{kind}.csv" for n in FEDERATES for kind in ("published", "received")),
)


# --- the arguments -----------------------------------------------------------------------------


def port_number(text):
    """A type for the broker's port: the first of PORTS ports on 127.0.0.1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if not 1024 <= value <= 65535 - PORTS:
        raise argparse.ArgumentTypeError(f"must be within 1024 to {65535 - PORTS}, not {text}")
    return value


def ports_free(first, n=PORTS):
    """Whether ports first .. first + n - 1 can be listened on at 127.0.0.1 (as zmq binds them)."""
    socks = []
    try:
        for port in range(first, first + n):
            s = socket.socket()
            socks.append(s)
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            s.bind(("127.0.0.1", port))
        return True
    except OSError:
        return False
    finally:
        for s in socks:
            s.close()


def choose_port(parser, port):
    """The --port given if its ports are free (else a usage error), or the first free block from
    DEFAULT_PORT on (two federations on one machine each get their own)."""
    if port is not None:
        if not ports_free(port):
            parser.error(
                f"argument --port: a port of {port} to {port + PORTS - 1} on 127.0.0.1 is in use "
                f"(another federation?); give another --port"
            )
        return port
    for port in range(DEFAULT_PORT, 65535 - PORTS, 20):
        if ports_free(port):
            return port
    parser.error("argument --port: no free block of ports on 127.0.0.1 from 23404 on")


def helics_command():
    """helics-cli's `helics`, beside this Python."""
    helics = Path(sys.executable).parent / "helics"
    if not helics.is_file():
        sys.exit(
            f"{cli.program_name()}: error: {helics} is missing: helics-cli comes with the [helics] extra: "
            f"pip install 'aem-electrolyser[helics]'"
        )
    return helics


# --- the runner file ---------------------------------------------------------------------------


def with_options(words, values):
    """The command line `words` with each `--name=value` of `values` ({name: value}) in place of
    the same option's value, or added at the end."""
    words = list(words)
    for name, value in values.items():
        option = f"--{name}="
        at = [i for i, w in enumerate(words) if w.startswith(option)]
        if at:
            words[at[0]] = f"{option}{value}"
        else:
            words.append(f"{option}{value}")
    return words


def option_value(words, name, default=None):
    """The value of `--name=value` in `words`, or default."""
    return next((w.split("=", 1)[1] for w in words if w.startswith(f"--{name}=")), default)


def runner_file(args, port, key):
    """The packaged runner file with this run's values: {federation}, as helics-cli reads it."""
    runner = json.loads(TEMPLATE.read_text())
    common = {
        "duration": args.duration,
        "brokerport": port,
        "brokerkey": key,
        "out": ".",
        "wall-limit": f"{args.wall_limit:g}",
    }
    if args.stall_timeout is not None:
        common["stall-timeout"] = f"{args.stall_timeout:g}"
    values = {
        "broker": {
            "port": port,
            "brokerkey": key,
            "maxcosimduration": f"{args.wall_limit:g}s",
            "wall-limit": f"{args.wall_limit + BROKER_GRACE:g}",
        },
        "wind": {**common, "seed": args.seed},
        "hub": {**common, "n-modules": args.modules, "dispatch": args.dispatch, "fmu": args.fmu.resolve()},
        "grid": {**common, **({} if args.fail_at is None else {"fail-at": f"{args.fail_at:g}"})},
    }
    for federate in runner["federates"]:
        words = shlex.split(federate["exec"])
        if words[0] == "python":
            words[0] = sys.executable  # this installation's, whatever PATH says
        federate["exec"] = shlex.join(with_options(words, values[federate["name"]]))
        federate["directory"] = "."  # the runner file's folder: the processes' working folder and the logs'
    return runner


# --- running -----------------------------------------------------------------------------------


class Rows:
    """The rows of a record written so far (read on from where the last look ended)."""

    def __init__(self, path):
        self.path, self.offset, self.lines = path, 0, 0

    def __call__(self):
        try:
            with open(self.path, "rb") as f:
                f.seek(self.offset)
                chunk = f.read()
        except FileNotFoundError:
            return 0
        self.offset += len(chunk)
        self.lines += chunk.count(b"\n")
        return max(0, self.lines - 1)  # without the header


def run_federation(args, out, path):
    """Runs helics-cli on the runner file; (its exit status, its output, wall time [s]). The bar
    follows the grid's record: the grid is granted t last, after the wind and the hub."""
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"}
    rows = Rows(out / "grid_published.csv")
    start = time.monotonic()
    with (
        open(out / "runner.log", "w") as log,
        cli.progress(total=args.duration, desc="simulated", unit="s", quiet=args.quiet) as bar,
    ):
        runner = subprocess.Popen(
            [str(helics_command()), "run", f"--path={path}", "--no-kill-on-error"],
            cwd=out,
            env=env,
            stdout=log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )  # one process group: the runner and what it starts
        try:
            while True:
                try:
                    runner.wait(timeout=POLL)
                    break
                except subprocess.TimeoutExpired:
                    pass
                done = min(args.duration, max(0, rows() - 1))  # rows at t = 0, 1, ...: t done
                if done > bar.n:
                    bar.update(done - bar.n)
                if time.monotonic() - start > args.wall_limit + BACKSTOP:
                    raise RuntimeError(
                        f"the federation still runs {args.wall_limit + BACKSTOP:g} s after it "
                        f"started (--wall-limit {args.wall_limit:g}): ended; logs in {out}"
                    )
        except BaseException:  # Ctrl-C, the backstop: end the runner and every process it started
            os.killpg(runner.pid, signal.SIGKILL)
            runner.wait()
            raise
    wall = time.monotonic() - start
    return runner.returncode, (out / "runner.log").read_text(errors="replace"), wall


def last_line(text):
    """The last line of text that is not blank, or None."""
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    return lines[-1] if lines else None


def log_end(path):
    """The last line of a log, or what is wrong with it."""
    try:
        return last_line(path.read_text(errors="replace")) or "(its log is empty)"
    except FileNotFoundError:
        return "(it left no log)"


def failure(out, status, output):
    """One line: the federate that failed first and why, in its own log's words."""
    failed = dict(re.findall(r"Process (\S+) exited with return code (-?\d+)", output))
    if not failed:
        why = last_line(output) or f"helics run ended with status {status}"
        return f"the federation did not run: {why} (helics-cli's output: {out / 'runner.log'})"
    lines = {name: log_end(out / f"{name}.log") for name in failed}
    # the federate whose own error ended the federation (the others were stopped by it), else
    # the broker, whose last line repeats the first error
    own = [
        n
        for n in FEDERATES
        if n in failed
        and "by a federation error" not in lines[n]
        and "watchdog: the federate did not end" not in lines[n]
    ]
    first = own[0] if own else "broker" if "broker" in failed else next(iter(failed))
    line = lines[first].removeprefix(f"{first}: ")
    return f"the federation failed: {first} exited with status {failed[first]}: {line} (logs in {out})"


def check_complete(out, duration):
    """None if every process reported its end and every record covers t = 0 .. duration, else
    what is missing (helics-cli counts a process killed with SIGKILL as a success)."""
    if "the federation ended normally" not in (out / "broker.log").read_text(errors="replace"):
        return f"the broker did not report a normal end: {log_end(out / 'broker.log')}"
    for name in FEDERATES:
        if f"{name}: {duration} s simulated in" not in (out / f"{name}.log").read_text(errors="replace"):
            return f"{name} did not report its end: {log_end(out / f'{name}.log')}"
        for kind in ("published", "received"):
            t = np.array(read(out / f"{name}_{kind}.csv")[1])[:, 0]
            if not np.array_equal(t, np.arange(duration + 1.0)):
                return f"{name}_{kind}.csv does not hold t = 0 .. {duration} s"
    return None


# --- the results -------------------------------------------------------------------------------


def table(path):
    """{column header: array} of a record."""
    header, rows = read(path)
    data = np.array(rows, dtype=float).reshape(len(rows), len(header))
    return {h: data[:, i] for i, h in enumerate(header)}


def records(out):
    return {f"{n}_{kind}": table(out / f"{n}_{kind}.csv") for n in FEDERATES for kind in ("published", "received")}


def summarise(r, duration, wall, run):
    """The run's figures, units in the names. The hub holds w(t) over [t, t + 1 s] (HELICS gives it
    w(t) at t + 1 s), so the wind offered over the run is sum w(t) dt for t < duration; the hub's
    energy and hydrogen are the FMU's own integrals at the end; the exchange at the bus is, per
    step, the wind offered less the hub's energy over it (positive: surplus into the grid)."""
    wind = r["wind_published"]["wind/power [W]"]
    hub = r["hub_published"]
    energy, h2 = hub["hub/hubEnergy [J]"], hub["hub/hubH2Produced [kg]"]
    power = hub["hub/hubPower [W]"]
    step = wind[:-1] * 1.0 - np.diff(energy)  # J over each 1 s step
    voltage, slack = r["grid_published"]["grid/voltage [pu]"], r["grid_published"]["grid/slackPower [W]"]
    hub_mwh = (energy[-1] - energy[0]) / 3.6e9
    h2_kg = h2[-1] - h2[0]
    return {
        **run,
        "simulated duration [s]": duration,
        "wall time [s]": round(wall, 2),
        "wind energy [MWh]": wind[:-1].sum() / 3.6e9,
        "hub energy [MWh]": hub_mwh,
        "hydrogen [kg]": h2_kg,
        "specific energy [kWh/kg]": 1e3 * hub_mwh / h2_kg if h2_kg > 0 else None,
        "mean wind power [MW]": wind[:-1].mean() / 1e6,
        "mean hub power [MW]": hub_mwh * 3600 / duration,
        "hub power range [MW]": [power.min() / 1e6, power.max() / 1e6],
        "surplus into the grid [MWh]": np.clip(step, 0.0, None).sum() / 3.6e9,
        "drawn from the grid [MWh]": np.clip(-step, 0.0, None).sum() / 3.6e9,
        "slack power range [MW]": [slack.min() / 1e6, slack.max() / 1e6],
        "bus voltage range [pu]": [voltage.min(), voltage.max()],
    }


def report(s):
    """The summary as lines of text."""
    lo, hi = s["hub power range [MW]"]
    v0, v1 = s["bus voltage range [pu]"]
    k0, k1 = s["slack power range [MW]"]
    specific = "" if s["specific energy [kWh/kg]"] is None else f" ({s['specific energy [kWh/kg]']:.1f} kWh/kg)"
    return [
        f"HELICS federation: {s['simulated duration [s]']} s simulated in {s['wall time [s]']:.1f} s wall "
        f"(hub of {s['modules']} modules, {s['dispatch']} dispatch, wind seed {s['seed']}, {s['bus']})",
        f"  wind farm     {s['wind energy [MWh]']:10.3f} MWh   (mean {s['mean wind power [MW]']:.2f} MW)",
        f"  hub           {s['hub energy [MWh]']:10.3f} MWh   (mean {s['mean hub power [MW]']:.2f} MW, "
        f"{lo:.2f} to {hi:.2f} MW)",
        f"  hydrogen      {s['hydrogen [kg]']:10.2f} kg{specific}",
        f"  at {s['bus']}: {s['surplus into the grid [MWh]']:.3f} MWh of wind into the grid, "
        f"{s['drawn from the grid [MWh]']:.3f} MWh drawn from it",
        f"  slack power {k0:.1f} to {k1:.1f} MW; {s['bus']} {v0:.5f} to {v1:.5f} pu",
    ]


def plot(path, r, s):
    """The run as a figure, like aem_electrolyser.mosaik.cigre_scenario's."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = r["grid_received"]["time [s]"]
    minutes = s["simulated duration [s]"] >= 600
    tx = t / 60.0 if minutes else t
    wind = r["grid_received"]["wind/power [W]"] / 1e6
    hub = r["grid_received"]["hub/hubPower [W]"] / 1e6
    slack = r["grid_published"]["grid/slackPower [W]"] / 1e6
    v = r["grid_published"]["grid/voltage [pu]"]
    fig, ax = plt.subplots(4, 1, figsize=(9, 10), sharex=True)
    ax[0].plot(tx, wind, color="tab:gray", lw=1, label="wind farm (static generator)")
    ax[0].plot(tx, hub, color="tab:blue", lw=1, label=f"hub (load), {s['dispatch']} dispatch")
    ax[0].set_ylabel("power [MW]")
    ax[1].plot(tx, wind - hub, color="tab:green", lw=1, label=f"wind - hub at {s['bus']} (export)")
    ax[1].plot(tx, slack - slack[0], color="tab:red", lw=1, ls="--", label=f"slack power - {slack[0]:.1f} MW")
    ax[1].set_ylabel("power [MW]")
    ax[2].plot(tx, 1e3 * (v - v[0]), color="tab:purple", lw=1, label=f"{s['bus']} (from {v[0]:.4f} pu)")
    ax[2].set_ylabel("voltage change [mpu]")
    hub_r = r["hub_published"]
    ax[3].plot(
        hub_r["time [s]"] / 60.0 if minutes else hub_r["time [s]"],
        hub_r["hub/hubH2Produced [kg]"],
        color="tab:orange",
        lw=1,
        label=f"hydrogen produced ({s['hydrogen [kg]']:.1f} kg)",
    )
    ax[3].set_ylabel("hydrogen [kg]")
    ax[3].set_xlabel("time [min]" if minutes else "time [s]")
    for a in ax:
        a.grid(alpha=0.3)
        a.legend(fontsize=7, loc="best")
    fig.suptitle(f"{s['modules']} AEM modules and a 64 MW wind farm at {s['bus']} of the CIGRE HV grid (HELICS)")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


# --- the command ---------------------------------------------------------------------------------


def main(argv=None):
    parser = cli.CommandLine(description=__doc__)
    parser.add_argument(
        "--duration", type=cli.positive(int), default=3600, help="simulated time [s], in 1 s steps [default: 3600]"
    )
    cli.add_out_option(parser, Path("out") / "helics", "the runner file, records, logs, summary and figure")
    parser.add_argument(
        "--modules", type=cli.positive(int), default=N_MODULES, help=f"modules in the hub [default: {N_MODULES}]"
    )
    parser.add_argument(
        "--dispatch",
        type=cli.one_of(sorted(DISPATCHES)),
        default="equal",
        help="equal (every module the same share) or sequential (as few modules as possible, "
        "the others in standby) [default: equal]",
    )
    parser.add_argument("--seed", type=cli.non_negative(int), default=1, help="seed of the wind series [default: 1]")
    parser.add_argument(
        "--port",
        type=port_number,
        default=None,
        help=f"the broker's port; it and the next {PORTS - 1} must be free on 127.0.0.1 "
        f"[default: the first free block from {DEFAULT_PORT} on]",
    )
    parser.add_argument(
        "--wall-limit",
        type=cli.positive(float),
        default=1800.0,
        help="wall-clock limit [s] of every federate and of the broker's co-simulation [default: 1800]",
    )
    parser.add_argument(
        "--stall-timeout",
        type=cli.positive(float),
        default=None,
        help="no progress for this long [s] ends the federation with a diagnosis [default: the federates', 30]",
    )
    parser.add_argument(
        "--fail-at",
        type=cli.non_negative(float),
        metavar="T",
        help="the grid federate raises at simulated time T [s] (to try the failure handling)",
    )
    cli.add_fmu_option(parser)
    args = parser.parse_args(argv)
    require("helics", parser.prog)
    args.fmu = cli.resolve_fmu(parser, args)
    port = choose_port(parser, args.port)
    helics_command()
    if args.out.resolve() == TEMPLATE.parent:
        parser.error(f"argument --out: {args.out} is the package's own folder; give another")
    out = cli.writable_folder(args.out).resolve()

    for name in RESULTS:
        (out / name).unlink(missing_ok=True)
    runner = runner_file(args, port, f"aem-{uuid.uuid4().hex[:12]}")
    path = out / "federation.json"
    path.write_text(json.dumps(runner, indent=2) + "\n")
    grid_words = shlex.split(next(f["exec"] for f in runner["federates"] if f["name"] == "grid"))
    run = {
        "modules": args.modules,
        "dispatch": args.dispatch,
        "seed": args.seed,
        "bus": option_value(grid_words, "bus", "Bus 1"),
    }
    cli.say(args, f"HELICS federation: {args.duration} s simulated, broker at 127.0.0.1:{port}, results in {out}")

    status, output, wall = run_federation(args, out, path)
    if args.debug:
        print(output, file=sys.stderr, end="")
    problem = failure(out, status, output) if status != 0 else check_complete(out, args.duration)
    if problem is not None:
        print(f"{cli.program_name()}: error: {problem}", file=sys.stderr)
        return 1

    r = records(out)
    summary = summarise(r, args.duration, wall, run)
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    plot(out / "helics.png", r, summary)
    for line in report(summary):
        cli.say(args, line)
    cli.say(
        args,
        f"wrote {out}: summary.json, helics.png, the records <name>_published.csv and "
        f"<name>_received.csv, the logs <name>.log and runner.log, federation.json",
    )
    return 0


if __name__ == "__main__":
    cli.run_command(main)
