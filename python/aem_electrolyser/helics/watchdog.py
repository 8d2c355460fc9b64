"""A thread that ends a federate, and the federation with it, when it stops making progress.

HELICS propagates a federate's own errors (a global error ends every federate at once), but in
HELICS 3.6.1 over zmq a federate that dies without a word (SIGKILL, a crash in native code) is
not reliably detected: the others wait for its time request forever. The federate's main loop
marks each phase (`joining`: waiting for the federation to start, `computing` a step, `waiting`
in a HELICS call); the watchdog acts when

* the federate has run longer than its wall-clock limit [s], or
* the federation has not started within the join timeout [s] (HELICS waits for a federate that
  never comes forever), or
* a step of its own has lasted longer than the stall timeout [s]: reported as such; or
* a wait in HELICS has lasted WAIT_FACTOR times the stall timeout (later than a step, so that a
  federate stuck in its own step reports that first, even on a loaded machine where the others'
  probes are slow to be answered): diagnosed by asking every other federate for its time with
  asynchronous HELICS queries (a federate whose process is gone does not answer within
  PROBE_TIMEOUT): a silent federate is named; if all answer, the wait is reported after twice
  the stall timeout.

Acting means a HELICS global error with the diagnosis (every federate's pending call then raises
it), and, if the main thread has not ended GRACE seconds later, ending the process (status 3).
"""

import os
import sys
import threading
import time
import warnings

from aem_electrolyser.extras import needs

with needs("helics", __name__):
    import helics as h

PROBE_TIMEOUT = 2.0  # s a living federate's core takes at most to answer a query
GRACE = 10.0  # s the main thread gets to end after the global error
POLL = 0.2  # s
EXIT_STATUS = 3
WAIT_FACTOR = 1.5  # a wait is probed after this many stall timeouts, a step fires after one


class Watchdog:
    def __init__(self, fed, name, wall_limit, stall_timeout, join_timeout):
        self._fed, self.name = fed, name
        self.wall_limit, self.stall_timeout, self.join_timeout = wall_limit, stall_timeout, join_timeout
        self._lock = threading.Lock()
        self._phase, self._what, self._since = "computing", "start-up", time.monotonic()
        self._start = self._since
        self._done = threading.Event()
        self.fired = None  # the message of the global error this watchdog raised
        self._thread = threading.Thread(target=self._run, name=f"{name} watchdog", daemon=True)

    def start(self):
        self._thread.start()

    def mark(self, phase, what):
        """The federate now is `joining`, `computing` (its own work) or `waiting` (in HELICS) for `what`."""
        with self._lock:
            self._phase, self._what, self._since = phase, what, time.monotonic()

    def stop(self):
        self._done.set()

    def _run(self):
        probed, status = None, ""
        while not self._done.wait(POLL):
            now = time.monotonic()
            with self._lock:
                phase, what, since = self._phase, self._what, self._since
            if now - self._start > self.wall_limit:
                return self._fire(f"{self.name}: wall-clock limit of {self.wall_limit:g} s reached ({what})")
            idle = now - since
            if phase == "joining":
                if idle >= self.join_timeout:
                    try:
                        state = self.query("root", "current_state") or {}
                    except h.HelicsException:
                        state = {}
                    joined = [f["attributes"]["name"] for f in state.get("federates", [])]
                    return self._fire(
                        f"{self.name}: the federation has not started after {idle:.0f} s ({what}); "
                        f"joined: {', '.join(joined) or 'unknown (the broker does not answer)'}"
                    )
                continue
            if phase == "computing":
                if idle >= self.stall_timeout:
                    return self._fire(f"{self.name}: {what} has not finished after {idle:.0f} s (--stall-timeout)")
                continue
            if idle < WAIT_FACTOR * self.stall_timeout:
                continue
            if probed == since:
                if idle >= 2 * self.stall_timeout:
                    return self._fire(
                        f"{self.name}: no progress for {idle:.0f} s ({what}); every federate "
                        f"answers, so one of them is stuck: {status}"
                    )
                continue
            try:
                silent, status = self._probe()
            except h.HelicsException:  # the federate is ending meanwhile (freed under the probe)
                continue
            probed = since
            if silent:
                return self._fire(
                    f"{self.name}: no progress for {idle:.0f} s ({what}): {', '.join(silent)} "
                    f"{'does' if len(silent) == 1 else 'do'} not answer: its process has died "
                    f"or lost its connection"
                )

    def _probe(self):
        """(names of federates that do not answer, their time status as text)."""
        state = self.query("root", "current_state")
        if state is None:
            return ["the broker"], ""
        names = [f["attributes"]["name"] for f in state.get("federates", []) if f["attributes"]["name"] != self.name]
        queries = {n: self._start_query(n, "current_time") for n in names}
        deadline = time.monotonic() + PROBE_TIMEOUT
        while time.monotonic() < deadline and not all(h.helicsQueryIsCompleted(q) for q in queries.values()):
            time.sleep(0.05)
        silent, status = [], []
        for n, q in queries.items():
            if h.helicsQueryIsCompleted(q):
                r = self._answer(q)
                if isinstance(r, dict) and "granted_time" in r:
                    status.append(f"{n} granted t={r['granted_time']:g} s, requesting {r['requested_time']:g} s")
                else:
                    status.append(f"{n}: {r}")
            else:
                silent.append(n)
            h.helicsQueryFree(q)
        return silent, "; ".join(status)

    @staticmethod
    def _answer(q):
        with warnings.catch_warnings():  # an answer that is no JSON (e.g. from an ending federate) is text
            warnings.simplefilter("ignore", UserWarning)
            return h.helicsQueryExecuteComplete(q)

    def _start_query(self, target, question):
        q = h.helicsCreateQuery(target, question)
        h.helicsQueryExecuteAsync(q, self._fed)
        return q

    def query(self, target, question):
        """A query's answer (a dict), or None if none came within PROBE_TIMEOUT."""
        q = self._start_query(target, question)
        deadline = time.monotonic() + PROBE_TIMEOUT
        while not h.helicsQueryIsCompleted(q) and time.monotonic() < deadline:
            time.sleep(0.05)
        r = self._answer(q) if h.helicsQueryIsCompleted(q) else None
        h.helicsQueryFree(q)
        return r if isinstance(r, dict) else None

    def _fire(self, message):
        if self._done.is_set():  # the federate has ended meanwhile
            return
        self.fired = message
        print(f"{self.name}: watchdog: {message}", file=sys.stderr, flush=True)
        try:
            h.helicsFederateGlobalError(self._fed, EXIT_STATUS, message)
        except Exception as e:  # the federate may be ending already
            print(f"{self.name}: watchdog: could not raise the global error ({e})", file=sys.stderr, flush=True)
        if not self._done.wait(GRACE):
            print(
                f"{self.name}: watchdog: the federate did not end within {GRACE:g} s of the error: exiting",
                file=sys.stderr,
                flush=True,
            )
            os._exit(EXIT_STATUS)
