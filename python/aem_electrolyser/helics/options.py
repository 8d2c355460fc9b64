"""Command-line options shared by the federates of aem_electrolyser.helics (standard library only).

Each federate takes this federation's options (below) and its own; every other option goes to
HELICS's FederateInfo unchanged, so HELICS's own spellings work as its documentation gives them:
`--broker_address=tcp://10.0.0.5`, `--brokerport=23404`, `--brokerkey=KEY`, `--loglevel=summary`,
`--timeout=30s`, `--tick=5s`, `--querytimeout=2s` (`helics_broker --help` lists them all).
The parser is the package's (aem_electrolyser.cli.CommandLine): a bad value or an option that is
neither ours nor HELICS's is one line naming it, exit status 2, before the federate joins.
"""

from pathlib import Path

from aem_electrolyser.cli import CommandLine, add_out_option, did_you_mean, non_negative, positive

#: The federates' HELICS configuration files (hub.json, wind.json, grid.json) live beside this module.
HERE = Path(__file__).resolve().parent
DEFAULT_OUT = Path("out") / "helics"


def parser(description):
    """The package's parser with the options every federate of this federation takes."""
    p = CommandLine(
        description=description,
        quiet=False,
        epilog="Other options go to HELICS (e.g. --brokerport=23404, --loglevel=summary).",
    )
    add_out_option(p, DEFAULT_OUT, "the CSV records of what was published and received")
    p.add_argument(
        "--duration",
        type=positive(int),
        default=3600,
        help="simulated time [s]: grants at t = 0, 1, ..., duration [default: 3600]",
    )
    p.add_argument(
        "--wall-limit",
        type=positive(float),
        default=1800.0,
        help="wall-clock limit of the federate [s]; reaching it ends the federation [default: 1800]",
    )
    p.add_argument(
        "--stall-timeout",
        type=positive(float),
        default=30.0,
        help="no progress for this long [s] (a step, or a wait for a time grant) ends the "
        "federation with a diagnosis [default: 30]",
    )
    p.add_argument(
        "--join-timeout",
        type=positive(float),
        default=60.0,
        help="the federation not started this long [s] after this federate joined (a federate "
        "missing) ends it [default: 60]",
    )
    p.add_argument(
        "--fail-at",
        type=non_negative(float),
        metavar="T",
        help="raise an error when granted simulated time T [s] (to try the failure handling)",
    )
    return p


# HELICS's options for a federate's connection, timing and log (as `helics_broker --help` lists
# them; HELICS ignores '_' in the names); HELICS itself ignores an option it does not know, so a
# misspelt option is refused here instead
HELICS_SPELLINGS = (
    "broker broker_address brokerport brokerkey brokername brokerinit brokerinitstring autobroker port "
    "localport local_interface interface ipv4 ipv6 external local all network_connectivity portstart "
    "connectionport connectionaddress coretype coreinit coreinitstring corename loglevel consoleloglevel "
    "fileloglevel logfile force_logging_flush dumplog timeout networktimeout querytimeout tick granttimeout "
    "errortimeout maxcosimduration networkretries maxsize maxcount profiler profiler_append encrypted "
    "encryption_config slowresponding debugging disable_timer no_tick reuse_address noackconnect"
).split()
HELICS_OPTIONS = {o.replace("_", "") for o in HELICS_SPELLINGS}


def parse(p, argv=None):
    """(our options, HELICS's options as a list): an option p does not know goes to HELICS; one
    HELICS does not know either is a usage error (status 2)."""
    args, helics = p.parse_known_args(argv)
    for a in helics:
        name = a.split("=", 1)[0]
        if a.startswith("-") and name.lstrip("-").replace("_", "").lower() not in HELICS_OPTIONS:
            known = [o for action in p._actions for o in action.option_strings] + [f"--{o}" for o in HELICS_SPELLINGS]
            p.error(
                f"unknown option {name}{did_you_mean(name, known)}: neither an option of this federate nor "
                f"one of HELICS's (see --help and helics_broker --help)"
            )
    return args, helics
