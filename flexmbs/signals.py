"""How a command stops: the first SIGINT, SIGTERM or SIGHUP becomes one exception at a safe point.

:class:`StopRequest` records the signal, the handler raises :class:`Interrupted` (Ctrl-C) or
:class:`Stopped` where it lands, a stop dropped inside a ``__del__`` is sent again, and the commands
raise a recorded stop at their safe points (:func:`check_signals`).  The command line
(:mod:`flexmbs.cli`) installs the handlers and turns the exceptions into exit statuses 128 + n.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import time

SIGNAL_NAMES = {signal.SIGINT: "SIGINT", signal.SIGTERM: "SIGTERM", signal.SIGHUP: "SIGHUP"}


class Stopped(BaseException):
    """A run stopped by a signal (SIGINT, SIGTERM, SIGHUP); ``signum`` says which."""

    def __init__(self, signum: int):
        super().__init__(SIGNAL_NAMES.get(signum, str(signum)))
        self.signum = signum


class Interrupted(KeyboardInterrupt):
    """Ctrl-C (SIGINT), raised by the command's handler.

    A subclass, so that every ``except KeyboardInterrupt`` catches it, but not the class itself:
    with a bare ``KeyboardInterrupt``, 2 of 25 Ctrl-Cs 0.25–0.45 s after the start (numba loading)
    ended the process by SIGINT (status -2) after the command had printed its line and returned
    130; with the subclass none of 75 did.  CPython treats an exception of exactly that class
    specially (its "unhandled KeyboardInterrupt" exit re-raises SIGINT), the likely path, which a
    small reproducer did not show.
    """


class StopRequest:
    """The first stopping signal (SIGINT, SIGTERM, SIGHUP) of a command.

    The handler raises :class:`Interrupted` (SIGINT) or :class:`Stopped` where the
    signal lands.  Python runs a handler between any two bytecodes, also inside an
    object's ``__del__`` (numba and llvmlite release objects while the cached kernels
    load), and an exception raised there is printed and dropped: the stop would be lost
    (3 of 109 early Ctrl-Cs were).  So the request is recorded first; a dropped one is
    not printed, the signal is sent again (:func:`_unraisable`), and the command raises a
    recorded stop at its safe points (:func:`check_signals`: before the deck is read, at
    every output of the run, after it).

    Attributes
    ----------
    signum : int or None
        The first signal received; None before one.
    lost : bool
        Its exception was dropped in a ``__del__`` (seen by the unraisable hook).
    deferred : bool
        Signals are only recorded, never raised (:func:`deferred_signals`); the command
        polls :attr:`signum` (``flexmbs sweep``, whose waits run inside Dask).
    """

    def __init__(self):
        self.signum, self.lost, self.deferred = None, False, False

    def exception(self) -> BaseException:
        """The exception that stops the command."""
        return Interrupted() if self.signum == signal.SIGINT else Stopped(self.signum)


STOP = StopRequest()
"""The stop request of the running command (reset by :func:`install_signal_handlers`)."""


def _stop(signum, frame):
    """The first SIGINT, SIGTERM or SIGHUP stops the command (as Ctrl-C does); later ones are ignored,
    so that the results file is closed and one message printed — unless the first was lost (then the
    first's exception is raised again)."""
    if STOP.signum is not None and not STOP.lost:
        return
    STOP.signum = STOP.signum or signum
    STOP.lost = False
    if not STOP.deferred:
        raise STOP.exception()


def _unraisable(info) -> None:
    """Drop a stop raised inside a ``__del__`` quietly, mark it lost and send the signal again a moment
    later (from a thread: the handler then runs in the main thread's next bytecodes, most likely
    outside any ``__del__``); anything else goes to the hook that was installed before."""
    if isinstance(info.exc_value, (KeyboardInterrupt, Stopped)):
        STOP.lost = True
        threading.Thread(target=_send_again, args=(STOP.signum,), daemon=True).start()
        return
    _unraisable.previous(info)


def _send_again(signum: int, delay: float = 0.005) -> None:
    """Send ``signum`` to this process after ``delay`` s if the stop is still lost (:func:`_unraisable`)."""
    time.sleep(delay)
    if STOP.lost:
        os.kill(os.getpid(), signum)


_unraisable.previous = sys.unraisablehook


def install_signal_handlers() -> None:
    """Handle SIGINT, SIGTERM and SIGHUP from now on (:class:`StopRequest`); a new command starts unstopped."""
    STOP.__init__()
    if sys.unraisablehook is not _unraisable:
        _unraisable.previous, sys.unraisablehook = sys.unraisablehook, _unraisable
    for sig in SIGNAL_NAMES:
        signal.signal(sig, _stop)


def check_signals() -> None:
    """A safe point: raise the stop again if a signal came whose exception never reached the command."""
    if STOP.signum is not None and not STOP.deferred:
        STOP.lost = False  # raised now: a signal sent again meanwhile must not interrupt the clean-up
        raise STOP.exception()


@contextlib.contextmanager
def deferred_signals():
    """Within the block signals are recorded in :data:`STOP` and not raised (the block polls ``STOP.signum``)."""
    STOP.deferred = True
    try:
        yield STOP
    finally:
        STOP.deferred = False
