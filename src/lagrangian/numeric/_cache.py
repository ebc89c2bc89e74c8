"""The one cache of what is built numerically from an Equations object.

Every numeric model (:class:`NumericModel`, the compiled ones), the generated modules and the
analysis' per-Equations tables live in one dict per Equations object, keyed by a name ("scipy",
"numba", "c", "variational", ...); the entry goes when the Equations object does (a weak key), so
no module keeps a cache of its own.
"""

from __future__ import annotations

import threading
import weakref
from collections.abc import Callable
from typing import TypeVar

from ..equations import Equations

__all__ = ["cached", "per_equations"]

T = TypeVar("T")

#: Equations -> {name: what was built from it}.
CACHE: weakref.WeakKeyDictionary[Equations, dict] = weakref.WeakKeyDictionary()
_LOCK = threading.Lock()


def per_equations(equations: Equations) -> dict:
    """The dict of what is cached for `equations` (created empty on first use)."""
    per = CACHE.get(equations)
    if per is None:
        with _LOCK:
            per = CACHE.setdefault(equations, {})
    return per


def cached(equations: Equations, key: str, build: Callable[[], T]) -> T:
    """The entry `key` of `equations`, built by ``build()`` on first use (the first one built is
    kept when two threads build it at once)."""
    per = per_equations(equations)
    hit = per.get(key)
    if hit is None:
        value = build()
        with _LOCK:
            hit = per.setdefault(key, value)
    return hit
