"""The ``sdfpbr`` command's first lines. Until main() is ready to clean up after an interrupt,
Ctrl-C ends the process at once with one line and status 130 (there is nothing to clean up
yet): a KeyboardInterrupt raised inside an import would print a traceback. Python's own
start-up, before this module runs, is not sdfpbr's to handle."""
import os
import signal
import sys


def _interrupted(signum, frame) -> None:
    os.write(2, b"sdfpbr: interrupted\n")
    os._exit(130)


def quiet_interrupts() -> None:
    """From now on Ctrl-C prints one line and exits 130 (main() takes over while it works)."""
    signal.signal(signal.SIGINT, _interrupted)


def is_quiet(handler) -> bool:
    return handler is _interrupted


if signal.getsignal(signal.SIGINT) is signal.default_int_handler:   # not where it is ignored
    quiet_interrupts()


def run() -> None:
    from .main import main
    status = main()
    if signal.getsignal(signal.SIGINT) not in (signal.SIG_IGN, None):
        quiet_interrupts()     # the work is done: an interrupt during the exit hooks is one line
    sys.exit(status)
