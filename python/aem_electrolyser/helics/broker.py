#!/usr/bin/env python3
"""The HELICS broker of this federation, as a program that ends with the federation and says how.

    python -m aem_electrolyser.helics.broker -f3 [--coretype zmq] [--wall-limit 1800] [helics_broker's options]

Starts a broker through HELICS's API with the options given, which are those of `helics_broker`
(`-f3 --port=23404 --loglevel=warning --terminate_on_error --tick=1s --timeout=30s
--maxcosimduration=1800s --brokerkey=KEY --ipv4 ...`), waits until every federate has
disconnected and exits with status 0 if the broker logged no error, 1 with the first error (a
federate's global error, a lost connection, --maxcosimduration reached) if it did, 2 if it is
still connected after --wall-limit seconds. Its log goes to stderr.

Why not `helics_broker` itself: the pip package's `helics_broker` is a Python wrapper that starts
the real broker as a child process, and `helics run` ends a failed federation with SIGKILL,
which leaves that child running and holding its ports; this program is the broker.
"""

import os
import shlex
import sys
import time

from aem_electrolyser.cli import CommandLine, positive
from aem_electrolyser.extras import needs

with needs("helics", __name__):
    import helics as h
    from helics.capi import ffi

from aem_electrolyser.helics.diagnosis import core_owners, explain

LEVELS = {
    0: "error",
    3: "warning",
    6: "summary",
    9: "connections",
    12: "interfaces",
    15: "timing",
    18: "data",
    21: "debug",
    24: "trace",
}
_errors = []


@ffi.callback("void(int, const char *, const char *, void *)")
def _log(level, identifier, message, _user):
    text = ffi.string(message).decode(errors="replace")
    if text == "logging callback activated":  # HELICS logs this at level error
        return
    who = ffi.string(identifier).decode(errors="replace")
    if level <= h.HELICS_LOG_LEVEL_ERROR and text.strip():
        _errors.append(text)
    print(f"[broker] [{LEVELS.get(level, level)}] {who}: {text}", file=sys.stderr, flush=True)


def main():
    p = CommandLine(description=__doc__, quiet=False, epilog="Other options go to HELICS (helics_broker --help).")
    p.add_argument("--coretype", default="zmq", help="HELICS core type [default: zmq]")
    p.add_argument(
        "-f", "--federates", type=positive(int), default=1, help="federates to wait for (passed on) [default: 1]"
    )
    p.add_argument(
        "--wall-limit",
        type=positive(float),
        default=1800.0,
        help="end with status 2 if the federation still runs after this long [s] [default: 1800]",
    )
    args, init = p.parse_known_args()
    init = [f"--federates={args.federates}", *init]
    os.dup2(2, 1)  # HELICS prints its console log to stdout: the broker has no report, all goes to stderr
    broker = h.helicsCreateBroker(args.coretype, "", shlex.join(init))
    h.helicsBrokerSetLoggingCallback(broker, _log, ffi.NULL)
    print(
        f"[broker] {h.helicsBrokerGetIdentifier(broker)} at {h.helicsBrokerGetAddress(broker)}, "
        f"HELICS {h.helicsGetVersion()}, options: {shlex.join(init)}",
        file=sys.stderr,
        flush=True,
    )
    start, owners, known = time.monotonic(), {}, False
    query = h.helicsCreateQuery("broker", "current_state")
    while not h.helicsBrokerWaitForDisconnect(broker, 500):
        # who is in which core, to name a lost core; asked only until every federate has joined,
        # as queries keep the broker busy and HELICS pings its cores only when it has been idle
        if not known and not _errors:
            owners = core_owners(h.helicsQueryBrokerExecute(query, broker))
            known = sum(len(names.split(", ")) for names in owners.values()) >= args.federates
        if time.monotonic() - start > args.wall_limit:
            print(f"[broker] wall-clock limit of {args.wall_limit:g} s reached: disconnecting", file=sys.stderr)
            h.helicsBrokerDisconnect(broker)
            h.helicsCloseLibrary()
            return 2
    h.helicsBrokerFree(broker)
    h.helicsCloseLibrary()
    if _errors:
        print(f"broker: the federation ended with an error: {explain(_errors[0], owners)}", file=sys.stderr)
        return 1
    print(f"[broker] the federation ended normally after {time.monotonic() - start:.1f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
