#!/usr/bin/env python3
"""Prequalification of an electrolyser hub for frequency reserves, on the packaged FMU.

    aem-prequalify [--modules 25000] [--dispatch equal] [--baseline 80]
        [--compensation both] [--filter-zero SECONDS,...] [--optimise] [--optimise-dispatch]
        [--products all] [--parameter NAME=VALUE ...]
        [--out out/prequalification] [--no-plots]

For each hub (dispatch × baseline, each plain and/or with reserveCompensation) and each product
(Nordic FCR-D up and down, dynamic: the fast ramp test and the sine tests; FCR-N; FFR at
49.7/49.6/49.5 Hz; Continental FCR; aFRR and mFRR up and down) it runs the product's test
programme on the FMU (fmpy, 0.1 s steps, a fresh instance per test), evaluates every requirement
against its limit and searches by bisection the largest capacity that passes, up to what the
operating window allows at the baseline. Static FCR-D is not assessed: it presumes a relay-style
activation with a delayed, slow deactivation that the FMU does not implement.

The capacity reported, everywhere the same number, is the one to sell: the largest passing
capacity times the reduction factor K_red where the rules allow one (FCR-N, FCR-D); the capacity
before reduction appears only labelled as such. Writes, per hub, <out>/<hub>.md, .csv and .json
(each requirement: measured against its limit, pass/fail, K_red; the capacity in W and % of
rated power, the limiting requirement with its measured value against its limit) and, unless
--no-plots, PNG plots of every product's tests (at the capacity, or, where none passes, at the
smallest capacity tried), each naming the limiting requirement; then <out>/summary.md and .csv
(products × hubs) and prints the summary. Several values of --dispatch, --baseline, --products
are comma-separated. Jobs (hub × product) run in parallel processes (--workers, default one
per core).

The reserve control is a family: every module's setpoint pre-filtered so that the zero of the
current's transfer function K(τn s + 1)/((τp1 s + 1)(τp2 s + 1)) sits at τn (the FMU's
reserveFilterZero), anywhere in [τp1, τp2]; plain droop is τn = τz, reserveCompensation
τn = τp2. `--filter-zero` assesses given zeros as further hubs. `--optimise` searches, per
product and per dispatch and baseline, the zero that sells the most (aem_electrolyser.reserves.
optimise: a scan of [τp1, τp2] every 5 %, τz and τp2 among the zeros, each bisected only where it
passes a step above the best so far, then the three best maxima refined; no random draw) and
writes <out>/optimum.md, .csv and .json: the zero, the capacity against plain droop and
compensation, the limiting requirement, every margin at the optimum, whether the verdict holds
under every reading of the rules, and every zero tried; the optimum's report and plots are
<hub>_<product>_optimum.md and .png.

The dispatch is the other lever: at a baseline B the hub can run any count n of modules that
keeps each inside its window (from the fewest, sequential dispatch, to the most), each at B/n,
the others idle (off: a cold start away; a module stopped during a test waits in warm standby). `--optimise-dispatch` searches, per product and baseline, the count
that sells the most with plain droop (aem_electrolyser.reserves.dispatch_search: every count
where there are few, else the same scan and refinement), run by the FMU as target dispatch
(dispatchTargetSetpoint at the setpoint that draws B/n), and writes <out>/dispatch_optimum.md,
.csv and .json: the count, its target setpoint and capacity, against the fewest and the most
modules.

`--parameter NAME=VALUE` sets any other parameter of the FMU on every hub (repeatable), for
instance the grid side (auxiliaryPower, supplyNoLoadLoss, supplyLossVoltage,
supplyLossResistance, and gridSideReference = true: the baseline, the rated power and the
requests are then grid power, and the power assessed is what the grid sees, hubAcPower; without
it the stacks' hubPower) or the stack temperature (thermalModel = true).

Req. 8 (Nyquist stability) is judged at the prescribed periods and on the unit's own curve
(sine tests between them, refined until the verdict is certain); what is sold passes both.
Every report gives each limit's margin and the verdict under the readings the rules leave open
(steady-state window, interpolation, measurement filter); `--margin FRACTION` sells only what
passes Req. 8 at 0.43·(0.95 + FRACTION) and under every reading.

This is a model-based assessment of the test programme (Nordic FCR technical requirements
v1.1 of 28 March 2025 and test programme, Fingrid FFR, SO GL Annex V), not a prequalification
approval; rules that could not be confirmed are reported as unsure (informative).
"""

import argparse
import contextlib
import csv
import multiprocessing
import os
import queue
import re
import textwrap
import threading
import time
from concurrent.futures import FIRST_COMPLETED, FIRST_EXCEPTION, ProcessPoolExecutor, ThreadPoolExecutor, wait
from pathlib import Path

from aem_electrolyser import cli
from aem_electrolyser.hub.messages import FmuError
from aem_electrolyser.hub.runner import Hub, HubRunner
from aem_electrolyser.reserves import assess, dispatch_search, optimise, report
from aem_electrolyser.reserves.bisection import failing
from aem_electrolyser.reserves.products import BY_NAME, PRODUCTS, window_bound

DISPATCH = {"equal": 1, "sequential": 2}
POLICY = {1: "equal", 2: "sequential", 4: "target"}
#: belowMinimum per dispatch: equal keeps every module at minSetpoint at worst (the paper);
#: sequential and target dispatch put the modules they stop in warm standby (the ones not running
#: at the start are idle).
BELOW_MINIMUM = {1: 0, 2: 1, 4: 1}
#: The FMU's nModules is an FMI Integer (32 bits).
MAX_MODULES = 2**31 - 1


class JobError(RuntimeError):
    """A failure in a worker, as one line in its own words (picklable: one string argument,
    unlike some library exceptions, so that it reaches the parent intact)."""


# --- the work of one worker process -----------------------------------------------------------

_PROGRESS = None  # the queue of the worker's bisection steps (None: nobody listens)


def _start_worker(progress_queue):
    global _PROGRESS
    _PROGRESS = progress_queue


def job(fmu, hub, product_name, dt, margin=0.0):
    """One product on one hub (in a worker process): (CapacityResult, Run at it, Run just above
    it, rated power). Every bisection step is reported to the parent's progress bar. A failure
    is an FmuError (the FMU's own message) or a JobError, both with the product's name."""

    def step(n, most, capacity, passed):
        if _PROGRESS is not None:
            _PROGRESS.put((hub_label(hub), product_name, n, most, capacity, passed))

    with job_failures(hub, product_name):
        runner = HubRunner(fmu, hub)
        try:
            result, at, above = assess.largest(runner, BY_NAME[product_name], dt, on_step=step, margin=margin)
            return result, at, above, runner.rated_power
        finally:
            runner.close()


def beats_job(fmu, hub, product_name, dt, margin, floor):
    """Whether the product on the hub passes a bisection step (0.5 % of rated power) above
    `floor` [W] (in a worker process): False without a run where that is beyond the window."""
    with job_failures(hub, product_name):
        runner = HubRunner(fmu, hub)
        try:
            product = BY_NAME[product_name]
            capacity = floor + 0.005 * runner.rated_power
            upper = window_bound(product, runner.baseline, runner.least_power, runner.rated_power)
            if capacity > upper:
                return False
            run = assess.run_product(runner, product, capacity, dt, margin)
            return not failing(run.results, product.use_reduction)
        finally:
            runner.close()


@contextlib.contextmanager
def job_failures(hub, product_name):
    """A failure in a worker as one line: an FmuError (the FMU's own message) or a JobError, both
    with the product's name."""
    try:
        yield
    except FmuError as e:
        raise FmuError(f"{product_name}: {e}") from e
    except Exception as e:  # noqa: BLE001 - any failure crosses the process boundary as one line
        raise JobError(f"{product_name} on the hub ({hub.describe()}): {cli.one_line(e)}") from e


# --- names and figures --------------------------------------------------------------------------


def percent(fraction: float) -> str:
    """80 for 0.8, 80.5 for 0.805 (distinct baselines give distinct file names)."""
    return f"{round(100 * fraction, 6):g}"


def control_name(hub: Hub) -> str:
    if hub.filter_zero > 0:
        return f"zero{hub.filter_zero:.6g}s"
    return "compensated" if hub.compensation else "plain"


def policy_name(hub: Hub) -> str:
    return f"target {hub.dispatch_target:.4g} %" if hub.dispatch == 4 else POLICY[hub.dispatch]


def hub_name(hub: Hub) -> str:
    return f"{slug(policy_name(hub))}_{percent(hub.baseline)}pct_{control_name(hub)}"


def hub_label(hub: Hub) -> str:
    control = f" zero {hub.filter_zero:.4g} s" if hub.filter_zero > 0 else " compensated" if hub.compensation else ""
    return f"{policy_name(hub)} {percent(hub.baseline)} %{control}"


def slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "_", text.lower()).strip("_")


def power_text(w: float) -> str:
    """A power [W] in W, kW or MW with 4 significant digits (the summary's cells)."""
    scale, unit = (1e6, "MW") if abs(w) >= 1e6 else (1e3, "kW") if abs(w) >= 1e3 else (1.0, "W")
    return f"{w / scale:.4g} {unit}"


# --- plots --------------------------------------------------------------------------------------


def verdict(figures: report.Capacity, result, run) -> tuple:
    """(text, failing) for the plots of a product: its capacity and the limiting requirement
    with its measured value against its limit; failing if the run plotted fails."""
    head = f"Capacity: {report.capacity_sentence(figures)}."
    if result.capacity > 0:
        where = f"Plotted at {run.capacity:.0f} W, {figures.tested}."
    else:
        where = f"Plotted at {run.capacity:.0f} W, the smallest capacity tried: it fails."
    return f"{head} {where}\nLimiting requirement: {figures.detail}", result.capacity <= 0


def plot_job(folder: Path, stem: str, product_name: str, figures, result, run, title) -> list:
    """plot_product in a worker process (the product by its name: its tests are functions)."""
    return plot_product(folder, stem, BY_NAME[product_name], figures, result, run, title)


def plot_product(folder: Path, stem: str, product, figures, result, run, title) -> list:
    """Every test of `product` in `run` (and the Nyquist plot of its sine tests, if they ran),
    each with the verdict; returns the file names."""
    text, failing = verdict(figures, result, run)
    names = []
    for k, (signal, trace) in enumerate(run.tests):
        name = f"{stem}_{slug(product.name)}_{k + 1}.png"
        report.plot_time_test(
            folder / name,
            signal,
            trace,
            run.capacity,
            annotation=text,
            failing=failing,
            title=f"{title}: {signal.name}, C = {run.capacity:.0f} W\n" + textwrap.fill(report.DISCLAIMER, 130),
        )
        names.append(name)
    if run.points:
        name = f"{stem}_{slug(product.name)}_nyquist.png"
        report.plot_nyquist(
            folder / name,
            run.points,
            product.sine,
            dense=run.dense,
            annotation=text,
            failing=failing,
            title=f"{title}: sine tests at C = {run.capacity:.0f} W\n" + textwrap.fill(report.DISCLAIMER, 130),
        )
        names.append(name)
    return names


# --- the summary --------------------------------------------------------------------------------


def write_summary(out: Path, hubs, products, figures, rated):
    """summary.md and summary.csv: per product and hub, the capacity and what limits it."""
    rows = [(p.name, hub, figures[(hub, p.name)]) for p in products for hub in hubs]
    with open(out / "summary.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(
            [
                "product",
                "dispatch",
                "baseline [% of rated]",
                "compensation",
                "capacity [W]",
                "capacity [% of rated]",
                "capacity before reduction [W]",
                "reduction factor [1]",
                "limiting requirement",
                "reserve filter zero [s]",
            ]
        )
        for name, hub, c in rows:
            w.writerow(
                [
                    name,
                    POLICY[hub.dispatch],
                    percent(hub.baseline),
                    "on" if hub.compensation else "off",
                    f"{c.w:.0f}",
                    f"{c.pct:.2f}",
                    "" if c.before_reduction_w is None else f"{c.before_reduction_w:.0f}",
                    "" if c.reduction_factor is None else f"{c.reduction_factor:.6g}",
                    c.limiting,
                    f"{hub.filter_zero:.6g}" if hub.filter_zero > 0 else "",
                ]
            )
    lines = [
        f"# Capacity per product (rated power {rated / 1e6:.4g} MW)",
        "",
        f"**{report.DISCLAIMER}**",
        "",
        "The capacity to sell: the largest passing capacity, times the reduction factor K_red where the "
        "rules allow one (marked K_red). The per-hub reports give every requirement.",
        "",
        "| product | " + " | ".join(hub_label(h) for h in hubs) + " |",
        "|---|" + "---|" * len(hubs),
    ]
    for product in products:
        cells = []
        for hub in hubs:
            c = figures[(hub, product.name)]
            k = f", K_red {c.reduction_factor:.3f}" if c.reduction_factor is not None else ""
            cells.append(f"{power_text(c.w)} ({c.pct:.2f} %{k}): {c.limiting}")
        lines.append(f"| {product.name} | " + " | ".join(x.replace("|", "\\|") for x in cells) + " |")
    (out / "summary.md").write_text("\n".join(lines) + "\n")
    return rows


# --- the command line ---------------------------------------------------------------------------


def modules_count(text):
    value = cli.positive(int)(text)
    if value > MAX_MODULES:
        raise argparse.ArgumentTypeError(
            f"must be at most {MAX_MODULES} (the FMU's nModules is a 32-bit integer), not {text}"
        )
    return value


def baselines(text):
    """Comma-separated baselines in % of rated power, each within (0, 100]; fractions returned."""
    values = []
    for item in [x.strip() for x in text.split(",") if x.strip()] or [text]:
        try:
            value = float(item)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{item!r} is not a number (% of rated power)") from None
        if not 0.0 < value <= 100.0:
            raise argparse.ArgumentTypeError(f"each must be within (0, 100] % of rated power, not {item}")
        values.append(value / 100.0)
    return list(dict.fromkeys(values))


def zeros(text):
    """Comma-separated zeros [s], each finite and > 0."""
    values = []
    for item in [x.strip() for x in text.split(",") if x.strip()] or [text]:
        try:
            value = float(item)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{item!r} is not a number of seconds") from None
        if not (value > 0 and value < float("inf")):
            raise argparse.ArgumentTypeError(f"each must be a time constant > 0 s, not {item}")
        values.append(value)
    return list(dict.fromkeys(values))


def margin_fraction(text):
    """--margin: a fraction in [0, 0.5]."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number (a fraction of the radius 0.43, e.g. 0.05)")
    if not 0.0 <= value <= 0.5:
        raise argparse.ArgumentTypeError(f"{text} is outside [0, 0.5] (a fraction of the radius 0.43, e.g. 0.05)")
    return value


def parser():
    names = [p.name for p in PRODUCTS]
    p = cli.CommandLine(description=__doc__)
    cli.add_fmu_option(p)
    p.add_argument("--modules", type=modules_count, default=25_000, help="modules of the hub [default: 25000]")
    p.add_argument(
        "--dispatch",
        type=cli.list_of(tuple(DISPATCH)),
        default=["equal"],
        help="equal, sequential, comma-separated [default: equal]",
    )
    p.add_argument(
        "--baseline",
        type=baselines,
        default=[0.8],
        help="baseline consumption in %% of rated power, each within (0, 100] and at least the hub's "
        "least steady power; comma-separated [default: 80]",
    )
    p.add_argument(
        "--compensation",
        type=cli.one_of(("off", "on", "both")),
        default="both",
        help="reserveCompensation: off, on or both [default: both]",
    )
    p.add_argument(
        "--filter-zero",
        type=zeros,
        default=[],
        metavar="SECONDS,...",
        help="further hubs whose reserve control puts the transfer function's zero here "
        "(reserveFilterZero, within [tauPole1, tauPole2]), comma-separated",
    )
    p.add_argument(
        "--optimise",
        action="store_true",
        help="search per product the zero that sells the most (writes optimum.md, .csv, .json)",
    )
    p.add_argument(
        "--optimise-dispatch",
        action="store_true",
        help="search per product and baseline the number of running modules that sells the most, run "
        "as target dispatch (writes dispatch_optimum.md, .csv, .json)",
    )
    p.add_argument(
        "--products",
        type=cli.list_of(names),
        default=names,
        help=f"comma-separated, of: {', '.join(names)}; or all [default: all]",
    )
    p.add_argument(
        "--dt", type=cli.positive(float), default=0.1, help="test signal sampling and FMU step [s] [default: 0.1]"
    )
    p.add_argument(
        "--margin",
        type=margin_fraction,
        default=0.0,
        metavar="FRACTION",
        help="sell only what passes with this stated margin: Req. 8 asks for 0.43·(0.95 + FRACTION) and every "
        "reading of the rules that they leave open (steady-state window, interpolation, measurement filter) "
        "must pass too, e.g. 0.05 [default: 0, the rules' own limits]",
    )
    workers = p.add_argument(
        "--workers",
        dest="jobs",
        type=cli.positive(int),
        default=os.cpu_count() or 1,
        metavar="N",
        help="parallel worker processes [default: one per core]",
    )
    cli.add_old_spelling(p, workers, "--jobs")
    p.add_argument(
        "--parameter",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="another parameter of the FMU for every hub, by its model-description name (repeatable)",
    )
    cli.add_out_option(p, Path("out") / "prequalification", "the reports, plots and summary")
    p.add_argument("--no-plots", action="store_true", help="no PNG plots")
    cli.add_version_option(p)
    return p


#: Parameters the prequalification sets itself (per hub and per test).
OWN_PARAMETERS = {
    "nModules",
    "dispatch",
    "belowMinimum",
    "powerInput",
    "reserveCompensation",
    "reserveFilterZero",
    "dispatchTargetSetpoint",
    "fcrNCapacity",
    "fcrDUpCapacity",
    "fcrDDownCapacity",
    "fcrCapacity",
    "ffrCapacity",
    "ffrTriggerFrequency",
    "ffrSupportDuration",
}


def fmu_settings(p, args):
    """--parameter NAME=VALUE pairs, checked against the FMU's model description: a parameter
    the prequalification does not set itself, and a value of its type."""
    from fmpy import read_model_description

    variables = {v.name: v for v in read_model_description(str(args.fmu)).modelVariables}
    settable = sorted(
        n for n, v in variables.items() if v.causality == "parameter" and n not in OWN_PARAMETERS and v.type != "String"
    )
    settings = []
    for item in args.parameter:
        name, sep, text = item.partition("=")
        name, text = name.strip(), text.strip()
        if not sep or not name or not text:
            p.error(f"--parameter {item!r}: give NAME=VALUE")
        if name not in settable:
            near = cli.did_you_mean(name, settable)
            p.error(f"--parameter {name}: not a parameter this command lets you set{near}")
        kind = variables[name].type
        try:
            if kind == "Real":
                value = float(text)
            elif kind in ("Integer", "Enumeration"):
                value = int(text)
            elif text.lower() in ("true", "false"):
                value = text.lower()
            else:
                raise ValueError(text)
        except ValueError:
            p.error(f"--parameter {name}={text}: not a {'Boolean (true or false)' if kind == 'Boolean' else kind}")
        settings.append((name, value))
    return tuple(settings)


def check_baselines(p, args):
    """A baseline the hub cannot hold (equal dispatch: below every module at minSetpoint; the
    others: below one module at minSetpoint) is a usage error."""
    runner = HubRunner(args.fmu, Hub(args.modules, settings=args.settings))
    try:
        least = 100.0 * runner.least_power / runner.rated_power
    finally:
        runner.close()
    curve = module_curve(args)
    one = 100.0 * curve.power(curve.min_setpoint) / (args.modules * curve.power(curve.max_setpoint))
    for d in args.dispatch + (["sequential"] if args.optimise_dispatch else []):
        floor, what = (least, "every module at minSetpoint") if d == "equal" else (one, "one module at minSetpoint")
        low = [b for b in args.baseline if 100.0 * b < floor - 1e-9]
        if low:
            # Equal dispatch is the default --dispatch: below its floor, sequential dispatch (the
            # fewest modules) is what holds the baseline, for --optimise-dispatch as well.
            instead, sequential = "", f" give --dispatch sequential, which holds down to {one:.2f} %"
            if d == "equal" and 100.0 * low[0] >= one - 1e-9:
                also = "; --optimise-dispatch assesses the hubs of --dispatch too:"
                instead = (also if args.optimise_dispatch else ", or") + sequential
            p.error(
                f"--baseline: {100 * low[0]:g} % is below what {d} dispatch can hold, {floor:.2f} % of rated "
                f"({what}); give each within [{floor:.2f}, 100]{instead}"
            )


def module_curve(args):
    """One module's steady power curve and window (the FMU's start values under --parameter)."""
    from fmpy import read_model_description

    start = {v.name: v.start for v in read_model_description(str(args.fmu)).modelVariables}
    names = ("gain", "voltageIntercept", "ohmicResistance", "minSetpoint", "maxSetpoint")
    value = {**{n: float(start[n]) for n in names}, **{k: float(v) for k, v in args.settings if k in names}}
    return dispatch_search.ModuleCurve(*(value[n] for n in names))


class Jobs:
    """One pool of worker processes for a whole command. Searches that run side by side (each in
    a thread of the parent, see `each`) ask for their jobs with `run`: the jobs queue in the
    order asked, each (hub, product) once, and a worker never waits for a search to decide its
    next step while another search has work. A progress bar over the jobs asked so far (the
    latest bisection step in its postfix); the first failure cancels what has not started and
    is raised in every search that waits for it."""

    def __init__(self, args, desc="prequalification"):
        self.args, self.desc = args, desc
        self.futures = {}  # (hub, product name) -> Future
        self.lock = threading.Lock()

    def __enter__(self):
        context = multiprocessing.get_context()
        self.steps = context.Queue() if cli.shows_progress(self.args.quiet) else None
        self.bar = cli.progress(total=0, desc=self.desc, unit="job", quiet=self.args.quiet)
        self.pool = ProcessPoolExecutor(
            max_workers=self.args.jobs, mp_context=context, initializer=_start_worker, initargs=(self.steps,)
        )
        return self

    def __exit__(self, kind, error, trace):
        self.pool.shutdown(wait=kind is None, cancel_futures=kind is not None)
        self.bar.close()
        return False

    def run(self, keys):
        """{key: job(...)} of every (hub, product name) in `keys`, those not asked before submitted
        now; blocks until all of them are done. A key (hub, product name, floor [W]) asks
        beats_job instead: does it pass a step above the floor?"""
        with self.lock:
            for key in dict.fromkeys(keys):
                if key not in self.futures:
                    margin = getattr(self.args, "margin", 0.0)
                    if len(key) == 3:
                        hub, name, floor = key
                        future = self.pool.submit(beats_job, self.args.fmu, hub, name, self.args.dt, margin, floor)
                    else:
                        hub, name = key
                        future = self.pool.submit(job, self.args.fmu, hub, name, self.args.dt, margin)
                    future.add_done_callback(lambda _: self.bar.update(1))
                    self.futures[key] = future
            self.bar.total += len(self.futures) - self.bar.total
            self.bar.refresh()
            mine = {key: self.futures[key] for key in keys}
        pending = set(mine.values())
        while pending:
            finished, pending = wait(pending, timeout=0.25, return_when=FIRST_COMPLETED)
            _show_steps(self.steps, self.bar)
            for future in finished:
                future.result()  # the first failure, raised here
        return {key: future.result() for key, future in mine.items()}

    def capacities(self, keys):
        """The sellable capacity [W] of each (hub, product name) in `keys`, in their order (run
        as `run` runs them)."""
        done = self.run(keys)
        return [done[key][0].sellable for key in keys]

    def beats(self, keys, floor):
        """Whether each (hub, product name) in `keys` passes a bisection step above `floor` [W]
        (optimise.search's test of a branch and bound)."""
        done = self.run([(hub, name, floor) for hub, name in keys])
        return [done[(hub, name, floor)] for hub, name in keys]

    def each(self, work, items):
        """[work(item) for item in items], each in a thread of its own, all at once (their jobs
        share the pool). The first failure cancels the jobs not started (the other threads end
        on them) and is raised."""
        if len(items) <= 1:
            return [work(item) for item in items]
        with ThreadPoolExecutor(max_workers=len(items)) as threads:
            futures = [threads.submit(work, item) for item in items]
            finished, _ = wait(futures, return_when=FIRST_EXCEPTION)
            failed = [f for f in futures if f in finished and f.exception() is not None]
            if failed:
                self.pool.shutdown(wait=False, cancel_futures=True)
                raise failed[0].exception()
            return [f.result() for f in futures]


def _show_steps(steps, bar):
    if steps is None:
        return
    while True:
        try:
            hub, product, n, most, capacity, passed = steps.get_nowait()
        except queue.Empty:
            return
        bar.set_postfix_str(
            f"{product} @ {hub}: step {n} of ≤ {most}, {power_text(capacity)} {'passes' if passed else 'fails'}",
            refresh=True,
        )


# --- the reserve control that sells the most -----------------------------------------------------


def time_constants(args):
    """(τz, τp1, τp2) [s] of the hubs: the FMU's start values under --parameter."""
    from fmpy import read_model_description

    start = {v.name: v.start for v in read_model_description(str(args.fmu)).modelVariables}
    value = {**{n: float(start[n]) for n in ("tauZero", "tauPole1", "tauPole2")}, **dict(args.settings)}
    return tuple(float(value[n]) for n in ("tauZero", "tauPole1", "tauPole2"))


def control_hub(args, d, base, zero, taus):
    """The hub whose reserve control puts the zero at `zero` [s]: at τz plain droop, at the slow
    pole τp2 compensation (the same dynamics bit for bit, and jobs the plain run may have done)."""
    tau_zero, _, tau_slow = taus
    policy = DISPATCH[d]
    if zero == tau_zero:
        return Hub(args.modules, policy, BELOW_MINIMUM[policy], base, False, args.settings)
    if zero == tau_slow:
        return Hub(args.modules, policy, BELOW_MINIMUM[policy], base, True, args.settings)
    return Hub(args.modules, policy, BELOW_MINIMUM[policy], base, False, args.settings, zero)


def optimise_controls(args, products, jobs, taus):
    """{(dispatch, baseline, product name): (optimise.Search, the best hub)} over the reserve
    control's zero in [τp1, τp2], every search at once on `jobs` (a Jobs)."""
    tau_zero, t1, t2 = taus
    cases = [(d, base, product) for d in args.dispatch for base in args.baseline for product in products]

    def optimise_one(case):
        d, base, product = case

        def keys(zs):
            return [(control_hub(args, d, base, z, taus), product.name) for z in zs]

        search = optimise.search(
            lambda zs: jobs.capacities(keys(zs)),
            min(t1, t2),
            max(t1, t2),
            known=(tau_zero, t2),
            beats=lambda zs, floor: jobs.beats(keys(zs), floor),
        )
        return search, control_hub(args, d, base, search.best.zero, taus)

    found = jobs.each(optimise_one, cases)
    return {(d, base, product.name): f for (d, base, product), f in zip(cases, found)}


def write_optimum(args, optimum, done, rated):
    """optimum.md, .csv and .json, and each optimum's report and plots."""
    rows = []
    for (d, base, name), (found, best) in optimum.items():
        product = BY_NAME[name]
        result, at, above, _ = done[(best, name)]
        section = assess.section(product, result, at, above)
        c = report.capacity(section, rated)
        stem = f"{hub_name(best)}_{slug(name)}_optimum"
        run = assess.shown(result, at, above)
        if not args.no_plots and run is not None:
            section.plots = plot_product(args.out, stem, product, c, result, run, f"{name}, {hub_label(best)}")
        report.write_report(
            args.out, stem, [section], f"Reserve prequalification (model-based): {best.describe()}", rated
        )
        ends = {}
        for compensation in (False, True):
            policy = DISPATCH[d]
            key = (Hub(args.modules, policy, BELOW_MINIMUM[policy], base, compensation, args.settings), name)
            ends[compensation] = done[key][0].sellable if key in done else None
        limits = section.margins if result.capacity > 0 else []
        rows.append(
            {
                "product": name,
                "dispatch": d,
                "baseline [% of rated]": percent(base),
                "zero [s]": found.best.zero,
                "capacity [W]": c.w,
                "capacity [% of rated]": c.pct,
                "capacity before reduction [W]": c.before_reduction_w,
                "reduction factor [1]": c.reduction_factor,
                "plain droop [W]": None if ends[False] is None else float(round(ends[False])),
                "compensated [W]": None if ends[True] is None else float(round(ends[True])),
                "limiting requirement": c.limiting,
                "limiting detail": c.detail,
                "robust": report.robust_text(section),
                "margins at the optimum [1]": [(m.name, m.relative) for m in limits],
                "tried [(s, W, bound)]": found.table(),
            }
        )
    report.write_rows(
        args.out / "optimum",
        rows,
        leave_out=("margins at the optimum [1]", "tried [(s, W, bound)]", "limiting detail", "robust"),
    )
    cell = lambda w: "–" if w is None else power_text(w)  # noqa: E731
    lines = [
        f"# The reserve control that sells the most (rated power {rated / 1e6:.4g} MW)",
        "",
        f"**{report.DISCLAIMER}**",
        "",
        "Per product, the zero τn of K(τn s + 1)/((τp1 s + 1)(τp2 s + 1)) (the FMU's reserveFilterZero) "
        "with the largest capacity to sell (whole watts, as in every other file; where a reduction factor "
        "applies, K_red and the capacity before reduction it was applied to), against plain droop (τn = τz) "
        "and compensation (τn = τp2); the requirement that binds, whether the verdict holds under every "
        "reading of the rules (robust) or only under ours (on an edge), and the closest margins at the "
        "capacity tested before any reduction factor: each measured value's distance inside its limit, "
        "relative to the limit (the Nyquist distance's to the radius 0.43; a requirement that the "
        "reduction factor covers shows its K_red above the floor).",
        "",
        "| product | dispatch | baseline | zero | capacity | plain droop | compensated | limiting requirement | "
        "readings | closest margins |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        close = ", ".join(f"{n} {m:+.1%}" for n, m in row["margins at the optimum [1]"][:3]) or "–"
        sold = power_text(row["capacity [W]"])
        if row["reduction factor [1]"] is not None:
            sold += f" (K_red {row['reduction factor [1]']:.4f} of {power_text(row['capacity before reduction [W]'])})"
        lines.append(
            f"| {row['product']} | {row['dispatch']} | {row['baseline [% of rated]']} % | {row['zero [s]']:.4g} s | "
            f"{sold} | {cell(row['plain droop [W]'])} | {cell(row['compensated [W]'])} | "
            f"{row['limiting detail'].replace('|', '/')} | {row['robust'].replace('|', '/')} | {close.replace('|', '/')} |"
        )
    lines += ["", "Zeros tried (s: capacity; ≤: failed a step above the best found before it):", ""]
    for row in rows:
        tried = ", ".join(f"{z:.4g}: {'≤ ' if b else ''}{power_text(c)}" for z, c, b in row["tried [(s, W, bound)]"])
        lines.append(f"- {row['product']}, {row['dispatch']} {row['baseline [% of rated]']} %: {tried}")
    (args.out / "optimum.md").write_text("\n".join(lines) + "\n")
    for row in rows:
        cli.say(
            args,
            f"optimum {row['product']:<16} {row['dispatch']} {row['baseline [% of rated]']} %: zero {row['zero [s]']:.4g} s, "
            f"{power_text(row['capacity [W]'])} (plain {cell(row['plain droop [W]'])}, compensated "
            f"{cell(row['compensated [W]'])}); limiting: {row['limiting requirement']}",
        )


# --- the dispatch that sells the most -----------------------------------------------------------


def count_hub(args, base, count, curve):
    """The hub that runs `count` modules at baseline `base` (target dispatch), plain droop."""
    target = dispatch_search.target_setpoint(count, base * args.modules * curve.power(curve.max_setpoint), curve)
    return Hub(args.modules, 4, BELOW_MINIMUM[4], base, False, args.settings, dispatch_target=target)


def optimise_dispatch(args, products, jobs):
    """{(baseline, product name): (dispatch_search.Found, feasible counts)}: per product and
    baseline the running count that sells the most, every search at once on `jobs` (a Jobs)."""
    curve = module_curve(args)
    rated = args.modules * curve.power(curve.max_setpoint)
    cases = [(base, product) for base in args.baseline for product in products]

    def optimise_one(case):
        base, product = case
        counts = dispatch_search.feasible_counts(args.modules, base * rated, curve)

        def capacities(ns):
            keys = [(count_hub(args, base, n, curve), product.name) for n in ns]
            return jobs.capacities(keys)

        return dispatch_search.search(capacities, counts), counts

    found = jobs.each(optimise_one, cases)
    return {(base, product.name): f for (base, product), f in zip(cases, found)}


def write_dispatch_optimum(args, dispatched, rated):
    """dispatch_optimum.md, .csv and .json: per product and baseline the best running count,
    its target setpoint and capacity, against the fewest and the most modules."""
    curve = module_curve(args)
    rows = []
    for (base, name), (found, counts) in dispatched.items():
        known = dict(found.tried)
        whole = lambda w: None if w is None else float(round(w))  # noqa: E731 - whole watts, as every file
        rows.append(
            {
                "product": name,
                "baseline [% of rated]": percent(base),
                "running modules [1]": found.count,
                "target setpoint [%]": dispatch_search.target_setpoint(found.count, base * rated, curve),
                "capacity [W]": whole(found.capacity),
                "fewest modules [1]": counts[0],
                "capacity with the fewest [W]": whole(known.get(counts[0])),
                "most modules [1]": counts[-1],
                "capacity with the most [W]": whole(known.get(counts[-1])),
                "counts tried [(1, W)]": found.table(),
            }
        )
    report.write_rows(args.out / "dispatch_optimum", rows, leave_out=("counts tried [(1, W)]",))
    cell = lambda w: "–" if w is None else power_text(w)  # noqa: E731
    lines = [
        f"# The dispatch that sells the most (rated power {rated / 1e6:.4g} MW, plain droop)",
        "",
        f"**{report.DISCLAIMER}**",
        "",
        "Per product and baseline, the number of running modules (each at the baseline's equal share, "
        "the others idle; the FMU's target dispatch) with the largest capacity, against the "
        "fewest modules that hold the baseline and the most, each run the same way (target dispatch at "
        "that count). The summary's sequential hub starts from the same fewest count but is another "
        "dispatch: sequential dispatch counts its modules for the demand with the reserve's request "
        "(it starts and stops modules as a test moves the power), target dispatch for the demand "
        "without it (the running modules share the request, their count changes only where the window "
        "requires), so their capacities may differ.",
        "",
        "| product | baseline | running modules | target setpoint | capacity | fewest modules | most modules |",
        "|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        lines.append(
            f"| {row['product']} | {row['baseline [% of rated]']} % | {row['running modules [1]']} | "
            f"{row['target setpoint [%]']:.4g} % | {power_text(row['capacity [W]'])} | "
            f"{row['fewest modules [1]']}: {cell(row['capacity with the fewest [W]'])} | "
            f"{row['most modules [1]']}: {cell(row['capacity with the most [W]'])} |"
        )
    (args.out / "dispatch_optimum.md").write_text("\n".join(lines) + "\n")
    for row in rows:
        cli.say(
            args,
            f"dispatch {row['product']:<16} {row['baseline [% of rated]']} %: {row['running modules [1]']} modules at "
            f"{row['target setpoint [%]']:.4g} %, {power_text(row['capacity [W]'])} (fewest "
            f"{cell(row['capacity with the fewest [W]'])}, most {cell(row['capacity with the most [W]'])})",
        )


def main(argv=None):
    p = parser()
    args = p.parse_args(argv)
    args.fmu = cli.resolve_fmu(p, args)
    args.settings = fmu_settings(p, args)
    check_baselines(p, args)
    cli.writable_folder(args.out)
    products = [BY_NAME[n] for n in args.products]
    modes = {"off": [False], "on": [True], "both": [False, True]}[args.compensation]
    taus = time_constants(args)
    lo, hi = min(taus[1:]), max(taus[1:])
    for z in args.filter_zero:
        if not lo <= z <= hi:
            p.error(
                f"--filter-zero: {z:g} s lies outside [{lo:g}, {hi:g}] s (tauPole1, tauPole2): "
                "the zero must lie between the poles"
            )
    hubs = [
        Hub(args.modules, DISPATCH[d], BELOW_MINIMUM[DISPATCH[d]], base, c, args.settings)
        for d in args.dispatch
        for base in args.baseline
        for c in modes
    ] + [
        Hub(args.modules, DISPATCH[d], BELOW_MINIMUM[DISPATCH[d]], base, False, args.settings, z)
        for d in args.dispatch
        for base in args.baseline
        for z in args.filter_zero
    ]
    start = time.perf_counter()
    with Jobs(args) as jobs:
        jobs.run([(hub, p_.name) for hub in hubs for p_ in products])
        optimum = optimise_controls(args, products, jobs, taus) if args.optimise else None
        dispatched = optimise_dispatch(args, products, jobs) if args.optimise_dispatch else None
        done = {key: future.result() for key, future in jobs.futures.items()}
        elapsed = time.perf_counter() - start
        rated = next(iter(done.values()))[3]
        figures, sections, plots = {}, {}, {}
        for hub in hubs:
            for product in products:
                result, at, above, _ = done[(hub, product.name)]
                section = sections[(hub, product.name)] = assess.section(product, result, at, above)
                c = figures[(hub, product.name)] = report.capacity(section, rated)
                run = assess.shown(result, at, above)
                if not args.no_plots and run is not None:  # drawn by the workers, side by side
                    title = f"{product.name}, {hub_label(hub)}"
                    plots[(hub, product.name)] = jobs.pool.submit(
                        plot_job, args.out, hub_name(hub), product.name, c, result, run, title
                    )
        for key, future in plots.items():
            sections[key].plots = future.result()
    for hub in hubs:
        report.write_report(
            args.out,
            hub_name(hub),
            [sections[(hub, product.name)] for product in products],
            f"Reserve prequalification (model-based): {hub.describe()}",
            rated,
        )
    rows = write_summary(args.out, hubs, products, figures, rated)
    if optimum is not None:
        write_optimum(args, optimum, done, rated)
    if dispatched is not None:
        write_dispatch_optimum(args, dispatched, rated)
    cli.say(args, f"{'product':<16} {'hub':<24} {'capacity':<34} limiting requirement")
    for name, hub, c in rows:
        k = f", K_red {c.reduction_factor:.3f}" if c.reduction_factor is not None else ""
        cli.say(args, f"{name:<16} {hub_label(hub):<24} {f'{power_text(c.w)} ({c.pct:.2f} %{k})':<34} {c.limiting}")
    cli.say(args, f"{len(hubs)} hub(s) x {len(products)} product(s) assessed in {elapsed:.1f} s; reports in {args.out}")
    return 0


if __name__ == "__main__":
    cli.run_command(main)
