"""The FMU's own words: its log messages, and the error a refused call raises.

fmpy's native logger proxy formats the FMU's variadic logger call and forwards it to one Python
callback per process (`callbacks()`); the messages are kept here, by text and count, not printed.
A call the FMU refuses raises `FmuError` with the FMU's last message: an exception with one
argument, so that it crosses a process pool (pickling) intact, unlike fmpy's FMICallException.
"""
import ctypes
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


def _log(env, instance_name, status, category, message):
    text = message.decode(errors="replace")
    MESSAGES[text] = MESSAGES.get(text, 0) + 1
    if status >= 2:
        _LAST_REFUSAL[0] = text


_LOGGER = fmi2CallbackLoggerTYPE(_log)


def callbacks():
    """fmi2CallbackFunctions whose logger records into MESSAGES."""
    functions = fmi2CallbackFunctions()
    functions.logger = _LOGGER
    addLoggerProxy(ctypes.byref(functions))
    return functions


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
