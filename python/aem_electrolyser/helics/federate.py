"""One federate of this federation: a HELICS value federate made from its JSON config, which
records what it publishes and receives, is watched (watchdog.py) and turns its own errors into
HELICS global errors, so that no federate is left waiting for one that has failed.

    args, helics_args = options.parse(parser)
    with Federate(HERE / "hub.json", args, helics_args) as fed:
        fed.enter_executing()
        for t in fed.times():                     # t = 0, 1, ..., duration [s]; 1 s apart
            u = fed.receive(t)                    # {input key: value}, recorded
            fed.publish(t, hubPower=...)          # every publication, recorded

The config (HELICS's JSON format) gives the name, core type, period, flags, log level and the
interfaces with their units; the command line adds the connection (HELICS's options, passed on
unchanged). An exception inside the `with` ends the federate with status 1 and a message naming
it; unless the federation already is in error, it is first raised as a global error, so every
other federate's pending HELICS call raises it too.
"""

import os
import shlex
import sys
import time
import traceback
from pathlib import Path

from aem_electrolyser.cli import quiet_on_closed_stdout
from aem_electrolyser.extras import needs

with needs("helics", __name__):
    import helics as h

from aem_electrolyser.helics.diagnosis import core_owners, explain
from aem_electrolyser.helics.records import Record
from aem_electrolyser.helics.watchdog import Watchdog


class FederationEnded(RuntimeError):
    """HELICS granted another time than requested: the broker ended the co-simulation."""


def run_federate(main):
    """Runs a federate's main as a command (cli.quiet_on_closed_stdout) and ends the process with
    its status at once, past the interpreter's exit: HELICS's library, once the broker is gone,
    can abort in its destructors at exit (std::bad_alloc thrown from its comms thread), which
    would turn the federate's status 1 and its last line into a SIGABRT."""
    try:
        quiet_on_closed_stdout(main)
        code = 0
    except SystemExit as e:
        code = e.code
        if isinstance(code, str):
            print(code, file=sys.stderr)
            code = 1
        elif code is None:
            code = 0
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (BrokenPipeError, ValueError):
            pass
    os._exit(code)


def report_stream():
    """A stream to the real stdout for the federate's one-line report; from here on everything
    else written to file descriptor 1 (HELICS's console log, an FMU's or fmpy's messages, print)
    goes to stderr."""
    report = os.fdopen(os.dup(1), "w", buffering=1)
    sys.stdout.flush()
    os.dup2(2, 1)
    return report


class Federate:
    def __init__(self, config, args, helics_args):
        self.args, self.t, self.started, self.owners = args, None, None, {}
        info = h.helicsCreateFederateInfo()
        try:
            h.helicsFederateInfoLoadFromString(info, shlex.join([f"--config={config}", *helics_args]))
            self.fed = h.helicsCreateValueFederate("", info)
        except h.HelicsException as e:
            raise SystemExit(f"{Path(config).stem}: cannot join the federation: {e}")
        h.helicsFederateInfoFree(info)
        self.name = h.helicsFederateGetName(self.fed)
        self.pubs = {}
        for i in range(h.helicsFederateGetPublicationCount(self.fed)):
            pub = h.helicsFederateGetPublicationByIndex(self.fed, i)
            self.pubs[h.helicsPublicationGetName(pub).split("/", 1)[-1]] = pub
        self.inputs = {}
        for i in range(h.helicsFederateGetInputCount(self.fed)):
            inp = h.helicsFederateGetInputByIndex(self.fed, i)
            h.helicsInputSetDefaultDouble(inp, float("nan"))  # nothing received yet
            self.inputs[h.helicsInputGetName(inp).split("/", 1)[-1]] = inp
        out = Path(args.out)
        self._published = Record(
            out / f"{self.name}_published.csv",
            [(h.helicsPublicationGetName(p), h.helicsPublicationGetUnits(p)) for p in self.pubs.values()],
        )
        self._received = (
            Record(
                out / f"{self.name}_received.csv",
                [(h.helicsInputGetTarget(i), h.helicsInputGetExtractionUnits(i)) for i in self.inputs.values()],
            )
            if self.inputs
            else None
        )
        self.watchdog = Watchdog(self.fed, self.name, args.wall_limit, args.stall_timeout, args.join_timeout)
        self.watchdog.start()

    # --- logging through HELICS, at its log levels -------------------------------------------
    def log(self, message, level=h.HELICS_LOG_LEVEL_SUMMARY):
        h.helicsFederateLogLevelMessage(self.fed, level, message)

    # --- the federate's life ---------------------------------------------------------------
    def enter_initializing(self):
        self.watchdog.mark("joining", "entering initializing mode")
        h.helicsFederateEnterInitializingMode(self.fed)
        self.watchdog.mark("computing", "initialization")

    def enter_executing(self):
        self.watchdog.mark("joining", "entering executing mode")
        h.helicsFederateEnterExecutingMode(self.fed)
        self.started = time.perf_counter()
        self.owners = core_owners(self.watchdog.query("root", "current_state"))  # to name lost cores
        self._granted(0.0, h.helicsFederateGetCurrentTime(self.fed))

    def times(self):
        """The granted times 0, 1, ..., duration [s]; after each, requests the next one; after the
        last, duration + 1 s, which is granted once every other federate has finished duration."""
        t = self.t
        while True:
            yield t
            if t >= self.args.duration:
                # done: one more period, granted once the others have finished their last step, so
                # that no value published at t is sent to a federate gone, nor an error missed
                self.watchdog.mark("waiting", f"finished t={t:g} s, waiting for the others to finish")
                h.helicsFederateRequestTime(self.fed, t + 1.0)
                return
            self.watchdog.mark("waiting", f"requesting t={t + 1:g} s")
            t = self._granted(t + 1.0, h.helicsFederateRequestTime(self.fed, t + 1.0))

    def _granted(self, requested, granted):
        if granted != requested:
            raise FederationEnded(
                f"granted t={granted:g} s instead of t={requested:g} s: the broker ended the "
                f"co-simulation (its --maxcosimduration, or a lost connection)"
            )
        self.t = granted
        self.watchdog.mark("computing", f"its step at t={granted:g} s")
        if self.args.fail_at is not None and granted >= self.args.fail_at:
            raise RuntimeError(f"simulated failure at t={granted:g} s (--fail-at)")
        return granted

    def publish_initial(self, **values):
        """Publish in initializing mode: received at t = 0 by every federate (not recorded)."""
        for key, value in values.items():
            h.helicsPublicationPublishDouble(self.pubs[key], float(value))

    def publish(self, t, **values):
        """Publish every publication [its unit] at the granted time t [s] and record them."""
        if set(values) != set(self.pubs):
            raise KeyError(f"{self.name} publishes {sorted(self.pubs)}, got {sorted(values)}")
        for key, pub in self.pubs.items():
            h.helicsPublicationPublishDouble(pub, float(values[key]))
        self._published.write(t, [values[k] for k in self.pubs])

    def receive(self, t):
        """{input key: latest value [its unit], NaN before the first} at the granted time t [s], recorded."""
        values = {key: h.helicsInputGetDouble(inp) for key, inp in self.inputs.items()}
        self._received.write(t, list(values.values()))
        return values

    def elapsed(self):
        """Wall time [s] since executing mode was entered."""
        return time.perf_counter() - self.started

    # --- the end -----------------------------------------------------------------------------
    def __enter__(self):
        return self

    def __exit__(self, kind, error, _traceback):
        self.watchdog.mark("computing", "its disconnect")
        for record in (self._published, self._received):
            if record is not None:
                record.close()
        message = None
        if error is not None:
            at = "" if self.t is None else f" at t={self.t:g} s"
            if isinstance(error, h.HelicsException):
                message = f"stopped{at} by a federation error: {explain(str(error), self.owners)}"
            else:
                message = f"failed{at}: {kind.__name__}: {error}"
                if not isinstance(error, FederationEnded):
                    traceback.print_exception(kind, error, _traceback, file=sys.stderr)
            try:
                if h.helicsFederateGetState(self.fed) != h.HELICS_STATE_ERROR:
                    h.helicsFederateGlobalError(self.fed, 1, f"{self.name} {message}")
            except h.HelicsException:
                pass
        try:
            h.helicsFederateDisconnect(self.fed)
        except h.HelicsException:
            pass
        h.helicsFederateFree(self.fed)
        h.helicsCloseLibrary()
        self.watchdog.stop()
        if message is not None:
            if self.watchdog.fired and self.watchdog.fired not in message:
                message += f" (this federate's watchdog: {self.watchdog.fired})"
            raise SystemExit(f"{self.name}: {message}")
        return False
