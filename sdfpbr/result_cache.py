"""Results a process keeps within a byte budget, the least recently used dropped first: the
same FLIP pair or sheet render asked for again in one gallery build is not computed again."""
from __future__ import annotations

from typing import Callable, Hashable


class ResultCache:
    """A dict of results bounded by their total size (``size(value)`` bytes); the most
    recently used last. At least the newest entry is kept, whatever its size."""

    def __init__(self, budget: int, size: Callable[[object], int]):
        self.budget = budget
        self._size = size
        self._values: dict = {}
        self._total = 0      # the sizes of the values kept, summed as they come and go

    def get(self, key: Hashable):
        """The value kept under ``key`` (now the most recently used), or None."""
        if key not in self._values:
            return None
        value = self._values[key] = self._values.pop(key)
        return value

    def put(self, key: Hashable, value) -> None:
        if key in self._values:
            self._total -= self._size(self._values.pop(key))
        self._values[key] = value
        self._total += self._size(value)
        while len(self._values) > 1 and self._total > self.budget:
            self._total -= self._size(self._values.pop(next(iter(self._values))))

    def __contains__(self, key) -> bool:
        return key in self._values

    def __len__(self) -> int:
        return len(self._values)

    def clear(self) -> None:
        self._values.clear()
        self._total = 0
