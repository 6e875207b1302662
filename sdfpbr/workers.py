"""Worker processes, the one way sdfpbr starts them: process pools whose workers start clean
(spawned, and each makes its own GL context if it needs one; no GL state is forked), ignore
Ctrl-C (it reaches the whole process group; the parent alone answers it, so no worker prints a
KeyboardInterrupt traceback) and exit on their own when the process that made the pool dies,
instead of working for nobody. helper_pool: such workers taking CPU work off a process that
draws, as it draws (a gallery's comparisons, the bug catalog's cards), forked from a clean
server process (no GL state either) that imported what they need once."""
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


@contextmanager
def sigint_held():
    """SIGINT blocked in this (the main) thread while it starts processes. They inherit the
    mask, so a Ctrl-C during their start-up (the interpreter's imports, before ``_init`` can
    ignore it) waits instead of printing a KeyboardInterrupt traceback there; this process
    takes it as soon as the block ends."""
    import signal
    if threading.current_thread() is not threading.main_thread() or not hasattr(signal, "pthread_sigmask"):
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _pool_class():
    """ProcessPoolExecutor whose submit (where it starts its processes) holds SIGINT."""
    from concurrent.futures import ProcessPoolExecutor

    class Pool(ProcessPoolExecutor):
        def submit(self, fn, /, *args, **kwargs):
            with sigint_held():
                return super().submit(fn, *args, **kwargs)
    return Pool


def _init(parent: int, environ: dict, then) -> None:
    """A worker's start: Ctrl-C ignored (then unblocked: it was held while the worker
    started), ``environ`` set, a watch that exits when the process that made the pool
    (``parent``: for a helper, not the server it was forked from) is gone."""
    import signal
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    os.environ.update(environ)
    threading.Thread(target=_watch, args=(parent,), daemon=True).start()
    if then is not None:
        then()


def _watch(parent: int) -> None:
    """Exit when ``parent`` does. Its pidfd (Linux) becomes readable then, whoever this process's
    parent is and whatever process later takes its pid; elsewhere its pid is polled."""
    import select
    try:
        pidfd = os.pidfd_open(parent)
    except ProcessLookupError:
        os._exit(1)
    except (AttributeError, OSError):
        pidfd = None
    if pidfd is not None:
        select.select([pidfd], [], [])
        os._exit(1)
    while True:
        time.sleep(0.5)
        try:
            os.kill(parent, 0)
        except ProcessLookupError:
            os._exit(1)
        except OSError:
            pass


def process_pool(workers: int, environ: dict | None = None, initializer=None):
    """A ProcessPoolExecutor of ``workers`` processes as the module says; ``environ`` is set in
    each worker before anything else runs there (e.g. a thread count a library reads when it
    loads), then ``initializer`` (a module-level function) runs."""
    import multiprocessing
    return _pool_class()(workers, mp_context=multiprocessing.get_context("spawn"), initializer=_init,
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


def _helper_context():
    """Helpers fork from a server process that imported what they need once (multiprocessing's
    forkserver: itself a clean process, no GL state to fork), instead of each importing numpy,
    Pillow and the layout anew (~0.6 s of a core each); spawned where there is no forkserver."""
    import multiprocessing
    method = "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"
    return multiprocessing.get_context(method)


def start_helper_server(imports: tuple[str, ...]) -> None:
    """Start the server helpers fork from now, importing ``imports`` there, so that it does so
    while this process works alone (a gallery build making its keys). The first call decides
    what the server imports; helpers import the rest themselves."""
    context = _helper_context()
    if context.get_start_method() == "forkserver":
        from multiprocessing import forkserver
        context.set_forkserver_preload(list(imports))
        with sigint_held():   # the server imports before it ignores SIGINT; its forks inherit the mask
            forkserver.ensure_running()


def _start_helper(imports: tuple[str, ...], environ: dict, cwd: str) -> None:
    """A helper's start. Forked from a server started earlier, it takes the environment and
    working directory its pool's maker has now, as a spawned process would (a test's cache
    directory, a script that changed directory), then imports what its tasks need."""
    import importlib
    _as_helper()
    os.environ.clear()
    os.environ.update(environ)
    try:
        os.chdir(cwd)
    except OSError:
        pass
    for name in imports:
        importlib.import_module(name)


def _ready() -> None:
    """A task that makes the pool start a worker (ProcessPoolExecutor starts one per task)."""


@contextmanager
def helper_pool(tasks: int, imports: tuple[str, ...]):
    """A pool of ``helpers(tasks)`` helper processes (None where there are none), each started
    at once with ``imports`` (the modules the tasks need) loaded, so that they are ready while
    the caller draws its first. Closed on leaving; on an error its queued tasks are dropped."""
    import functools
    workers = helpers(tasks)
    if not workers:
        yield None
        return
    start_helper_server(imports)
    start = functools.partial(_start_helper, tuple(imports), dict(os.environ), os.getcwd())
    pool = _pool_class()(workers, mp_context=_helper_context(), initializer=_init,
                         initargs=(os.getpid(), {}, start))
    try:
        for _ in range(workers):
            pool.submit(_ready)
        yield pool
    except BaseException:
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    finally:
        pool.shutdown(wait=True)
