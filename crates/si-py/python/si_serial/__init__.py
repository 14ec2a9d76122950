"""si for Python: the SIMATIC ET 200S serial interface protocols for test rigs.

Blocking clients that release the GIL while they wait, on one shared runtime. Times are float
seconds. Every failure is an :class:`SiError` carrying the manual's STATUS word, every bad
parameter a :class:`ConfigError` (a :class:`ValueError`) naming the parameter, its range and
the value.
"""

from . import _si_serial
from ._si_serial import *  # noqa: F401,F403 (the extension's classes, exceptions, constants)

__all__ = [name for name in dir(_si_serial) if not name.startswith("_")]
