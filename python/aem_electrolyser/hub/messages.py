"""The FMU's own words: its log messages, and the error a refused call raises.

fmpy's native logger proxy formats the FMU's variadic logger call and forwards it to one Python
callback per process (`callbacks()`); the messages are kept here, by text and count, not printed.
A call the FMU refuses raises `FmuError` with the FMU's last message: an exception with one
argument, so that it crosses a process pool (pickling) intact, unlike fmpy's FMICallException.
"""

import ctypes
import sys
from contextlib import contextmanager

from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
from fmpy.logging import addLoggerProxy

#: The FMU's log messages of this process: text -> times logged.
MESSAGES = {}
#: The latest message with status fmi2Discard or worse ('' if none).
_LAST_REFUSAL = [""]


class FmuError(RuntimeError):
    """A call the FMU refused, in the FMU's own words (picklable: one string argument)."""


LABELS = ("OK", "WARNING", "DISCARD", "ERROR", "FATAL", "PENDING")


def _log(env, instance_name, status, category, message):
    """Keeps the message; a refusal (fmi2Discard or worse) is kept for the exception it causes."""
    text = message.decode(errors="replace")
    MESSAGES[text] = MESSAGES.get(text, 0) + 1
    if status >= 2:
        _LAST_REFUSAL[0] = text


def log_to_stderr(env, instance_name, status, category, message):
    """A logger (fmpy's signature, e.g. simulate_fmu(logger=...)): the FMU's warnings and
    information on stderr as fmpy prints them ("[WARNING] ..."); its refusals are kept for the
    one-line error they end in, not printed twice."""
    _log(env, instance_name, status, category, message)
    if status < 2:
        label = LABELS[status] if 0 <= status < len(LABELS) else str(status)
        print(f"[{label}] {message.decode(errors='replace')}", file=sys.stderr, flush=True)


_LOGGER = fmi2CallbackLoggerTYPE(_log)
_ECHO = fmi2CallbackLoggerTYPE(log_to_stderr)


def callbacks(echo=False):
    """fmi2CallbackFunctions whose logger records into MESSAGES (and with echo, prints the
    warnings as log_to_stderr does)."""
    functions = fmi2CallbackFunctions()
    functions.logger = _ECHO if echo else _LOGGER
    addLoggerProxy(ctypes.byref(functions))
    return functions


def instantiate(slave, echo=False):
    """slave.instantiate() (an fmpy FMU2Slave) with this module's logger; a refused instantiation
    raises FmuError with the FMU's reason (fmpy's own exception says only that it failed)."""
    _LAST_REFUSAL[0] = ""
    try:
        slave.instantiate(loggingOn=False, callbacks=callbacks(echo))
    except Exception:  # noqa: BLE001 - fmpy raises a plain Exception here
        raise refusal("to instantiate") from None


def refusal(what):
    """FmuError for a refused call `what` (e.g. 'fmi2DoStep at t = 3 s') with the FMU's last message."""
    said = _LAST_REFUSAL[0]
    _LAST_REFUSAL[0] = ""
    return FmuError(f"the FMU refused {what}: {said}" if said else f"the FMU refused {what}")


@contextmanager
def fmu_words(what):
    """Turns fmpy's FMICallException inside into FmuError with the FMU's own message."""
    _LAST_REFUSAL[0] = ""
    try:
        yield
    except FMICallException as e:
        said = _LAST_REFUSAL[0]
        raise refusal(what if said.startswith(e.function) else f"{what} ({e.function})") from None
