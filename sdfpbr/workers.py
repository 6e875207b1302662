"""Worker processes, the one way sdfpbr starts them: a process pool in the spawn context (each
worker starts clean and makes its own GL context if it needs one; no GL state is forked), whose
workers ignore Ctrl-C (it reaches the whole process group; the parent alone answers it, so no
worker prints a KeyboardInterrupt traceback) and exit on their own when their parent dies,
instead of working for nobody. helper_pool: such workers taking CPU work off a process that
draws, as it draws (a gallery's comparisons, the bug catalog's cards)."""
from __future__ import annotations

import os
import threading
import time
from contextlib import contextmanager


def cores() -> int:
    """The CPUs this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def can_spawn() -> bool:
    """Whether a spawned worker can start here: it re-runs the parent's main script, which a
    program read from stdin (``python - < script``) does not have as a file."""
    import sys
    main = getattr(sys.modules.get("__main__"), "__file__", None)
    return main is None or os.path.exists(main)


_helper = False     # whether this process is a helper_pool's worker


def in_helper() -> bool:
    """Whether this process is a helper (it starts no workers of its own)."""
    return _helper


def _as_helper() -> None:
    global _helper
    _helper = True


def _init(parent: int, environ: dict, then) -> None:
    import signal
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    os.environ.update(environ)

    def watch():
        while True:
            time.sleep(0.5)
            if os.getppid() != parent:
                os._exit(1)
    threading.Thread(target=watch, daemon=True).start()
    if then is not None:
        then()


def process_pool(workers: int, environ: dict | None = None, initializer=None):
    """A ProcessPoolExecutor of ``workers`` processes as the module says; ``environ`` is set in
    each worker before anything else runs there (e.g. a thread count a library reads when it
    loads), then ``initializer`` (a module-level function) runs."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor
    return ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"), initializer=_init,
                               initargs=(os.getpid(), dict(environ or {}), initializer))


# Helpers: worker processes that take CPU work (FLIP, page layout, PNG) off a process that
# draws, as it draws. Fewer tasks than this are done there: a worker's start costs ~0.5 s of a
# core, a task ~0.1-0.3 s. At most HELPERS_MAX: each holds numpy and Pillow (~40-80 MB), and one
# drawing process feeds no more.
HELPERS_FROM = 4
HELPERS_MAX = 8


def helpers(tasks: int) -> int:
    """Helper processes for ``tasks`` tasks (0: do them in this process): one per core (the
    drawing process leaves its core part idle: a gallery on 2 cores built in 13.2 s with one,
    12.5 with two); none on one core, in a helper, or where none can start. A `-j` build's
    worker may start them: its group of comparisons is the build's longest task (on 2 cores,
    -j 2 took 13.9 s with that worker composing its pages itself, -j 1 12.1 s)."""
    if tasks < HELPERS_FROM or cores() < 2 or in_helper() or not can_spawn():
        return 0
    return min(cores(), tasks, HELPERS_MAX)


@contextmanager
def helper_pool(tasks: int, warm):
    """A process_pool of ``helpers(tasks)`` workers (None where there are none), each started
    at once by running ``warm`` (a module-level function: what the tasks import), so that they
    start while the caller draws its first. Closed on leaving; on an error its queued tasks are
    dropped."""
    workers = helpers(tasks)
    if not workers:
        yield None
        return
    pool = process_pool(workers, initializer=_as_helper)
    try:
        for _ in range(workers):   # a pool starts a worker per task it is given
            pool.submit(warm)
        yield pool
    except BaseException:
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    finally:
        pool.shutdown(wait=True)
