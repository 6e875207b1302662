"""One progress reporter for long work (reference samples, animation frames, builds, sweeps).

On a terminal it is a tqdm bar when the ``progress`` extra is installed; otherwise (a pipe, a
CI log, no tqdm) it prints a plain line to stderr at most every ``every_s`` seconds and at the
end, so long work is never silent. Disabled, it prints nothing."""
from __future__ import annotations

import sys
import time


class Progress:
    def __init__(self, total: int, desc: str, unit: str = "it", enabled: bool = True,
                 every_s: float = 5.0, stream=None):
        self.total, self.desc, self.unit = int(total), desc, unit
        self.enabled, self.every_s = enabled, every_s
        self.stream = stream if stream is not None else sys.stderr
        self.done = 0
        self.bar = None
        self._last = time.monotonic()
        if enabled and getattr(self.stream, "isatty", lambda: False)():
            try:
                from tqdm import tqdm
            except ImportError:
                tqdm = None
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
