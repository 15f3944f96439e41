"""A least-recently-used cache of GL resources bounded in bytes, not in count.

Entries report their size with `nbytes()` and free themselves (attachments included)
with `release()`. Entries can grow after they are stored (render targets are allocated
lazily), so the budget is enforced by `trim()`, which the renderer calls after each
frame with the keys that frame used: those are never evicted, so one frame larger than
the whole budget still renders, and is released by the next trim.
"""

from __future__ import annotations

import time
from collections import OrderedDict
from typing import Any, Callable, Hashable, Iterable


class ByteLRU:
    def __init__(self, budget: int, clock: Callable[[], float] = time.monotonic):
        self.budget = int(budget)
        self.clock = clock
        self._items: OrderedDict[Hashable, Any] = OrderedDict()
        self._used: dict[Hashable, float] = {}   # when each entry was last asked for

    def get(self, key: Hashable, make: Callable[[], Any]) -> Any:
        """The entry for `key`, made with `make()` if missing; marks it most recent."""
        if key in self._items:
            self._items.move_to_end(key)
        else:
            self._items[key] = make()
        self._used[key] = self.clock()
        return self._items[key]

    def peek(self, key: Hashable) -> Any:
        """The entry for `key`, leaving its place and time as they are."""
        return self._items[key]

    def idle_for(self, key: Hashable) -> float:
        """Seconds since `key` was last asked for."""
        return self.clock() - self._used[key]

    def nbytes(self) -> int:
        return sum(v.nbytes() for v in self._items.values())

    def __len__(self) -> int:
        return len(self._items)

    def __contains__(self, key: Hashable) -> bool:
        return key in self._items

    def keys(self) -> list:
        return list(self._items)

    def pop(self, key: Hashable) -> None:
        item = self._items.pop(key, None)
        self._used.pop(key, None)
        if item is not None:
            item.release()

    def trim(self, keep: Iterable[Hashable] = (), budget: int | None = None,
             order: Iterable[Hashable] | None = None) -> int:
        """Release entries (other than `keep`) until the total is within the budget (or
        `budget`, for this call), least recently used first or in `order`; returns the
        bytes released."""
        keep = set(keep)
        limit = self.budget if budget is None else int(budget)
        total = self.nbytes()
        freed = 0
        for key in list(self._items) if order is None else list(order):
            if total <= limit:
                break
            if key in keep or key not in self._items:
                continue
            n = self._items[key].nbytes()
            self.pop(key)
            total -= n
            freed += n
        return freed

    def clear(self) -> None:
        for key in list(self._items):
            self.pop(key)
