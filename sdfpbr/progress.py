"""Progress for long work: ``Progress`` for work counted in units (reference samples,
animation frames, bugs, sweeps), ``Ticker`` for one long step whose size is not known (a chart:
its bakes and draws are single GPU calls).

On a terminal each is a tqdm bar when the ``progress`` extra is installed; otherwise (a pipe, a
CI log, no tqdm) a plain line on stderr at most every ``every_s`` seconds and at the end, so long
work is never silent. Disabled, they print nothing."""
from __future__ import annotations

import sys
import threading
import time
from typing import Callable

EVERY_S = 5.0   # seconds between plain progress lines; a Ticker's step shorter than this says nothing


def _on_terminal(stream) -> bool:
    return getattr(stream, "isatty", lambda: False)()


def _tqdm():
    try:
        from tqdm import tqdm
    except ImportError:
        return None
    return tqdm


class Progress:
    def __init__(self, total: int, desc: str, unit: str = "it", enabled: bool = True,
                 every_s: float = EVERY_S, stream=None):
        self.total, self.desc, self.unit = int(total), desc, unit
        self.enabled, self.every_s = enabled, every_s
        self.stream = stream if stream is not None else sys.stderr
        self.done = 0
        self.bar = None
        self._last = time.monotonic()
        tqdm = _tqdm() if enabled and _on_terminal(self.stream) else None
        if tqdm is not None:
            self.bar = tqdm(total=self.total, desc=desc, unit=unit, file=self.stream)

    def update(self, added: int = 1, note: str = "") -> None:
        """``added`` more units done; ``note`` is shown beside the count (e.g. an error)."""
        if not self.enabled:
            return
        self.done += added
        if self.bar is not None:
            self.bar.update(added)
            if note:
                self.bar.set_postfix_str(note, refresh=False)
            return
        now = time.monotonic()
        if now - self._last >= self.every_s or self.done >= self.total:
            self._last = now
            line = f"{self.desc}: {self.done}/{self.total} {self.unit} {note}".rstrip()
            print(line, file=self.stream, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class Ticker:
    """The elapsed time of one long step: nothing for its first ``every_s`` seconds (a quick step
    stays silent), then a tqdm counter on a terminal, else a line every ``every_s`` seconds
    through ``say`` (default: a line on ``stream``, stderr), and at the end how long it took
    (unless ``end`` is False: the caller says it). ``restart()`` starts the clock again (a
    build's next image: quiet while images keep coming).

    A thread keeps the time. It can speak only between GL calls, which hold Python's lock: a
    line that falls due during a long call (one pass of a bake can take seconds on a CPU renderer)
    comes when the call returns."""

    TICK_S = 1.0   # how often the thread looks at the clock (and moves a terminal's counter)

    def __init__(self, desc: str, enabled: bool = True, every_s: float = EVERY_S, stream=None,
                 say: Callable[[str], None] | None = None, end: bool = True):
        self.desc, self.enabled, self.every_s, self.end = desc, enabled, every_s, end
        self.stream = stream if stream is not None else sys.stderr
        self.say = say or (lambda line: print(line, file=self.stream, flush=True))
        self.tqdm = _tqdm() if say is None and _on_terminal(self.stream) else None
        self.bar = None
        self.shown = False
        self.start = time.monotonic()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="sdfpbr-ticker", daemon=True)

    def elapsed(self) -> float:
        return time.monotonic() - self.start

    def restart(self) -> None:
        self.start = time.monotonic()

    def _run(self) -> None:
        said = None   # when the last plain line was said
        while not self._stop.wait(min(self.TICK_S, self.every_s)):
            now = time.monotonic()
            if now - self.start < self.every_s or (self.tqdm is None and said is not None
                                                   and now - said < self.every_s):
                continue
            said, self.shown = now, True
            line = f"{self.desc}: {now - self.start:.0f} s"
            if self.tqdm is None:
                self.say(line)
            elif self.bar is None:
                self.bar = self.tqdm(total=None, desc=line, file=self.stream, bar_format="{desc}", leave=False)
            else:
                self.bar.set_description_str(line)

    def __enter__(self) -> "Ticker":
        self.start = time.monotonic()
        if self.enabled:
            self._thread.start()
        return self

    def __exit__(self, kind, *exc) -> None:
        if not self.enabled:
            return
        self._stop.set()
        self._thread.join()
        if self.bar is not None:
            self.bar.close()
        if self.shown and self.end and kind is None:
            self.say(f"{self.desc}: done in {self.elapsed():.1f} s")
