"""A worker's cache of loaded and sampled parts, keyed by the content hash of the part's bytes,
least recently used first out when the total size exceeds the memory bound (cachetools'
`LRUCache` sized by each entry's bytes)."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from cachetools import LRUCache

from checker.errors import PathcheckError


@dataclass
class CachedPart:
    """A part, its test points, their size in bytes and the seconds spent loading and sampling."""

    part: Any
    test_points: Any
    nbytes: int
    load_s: float
    sample_s: float


class _LruBytes(LRUCache):
    """cachetools' LRU of CachedPart bounded by the sum of their `nbytes`, counting what it
    evicts (cachetools evicts through `popitem`)."""

    def __init__(self, max_bytes: int) -> None:
        super().__init__(maxsize=max_bytes, getsizeof=lambda entry: entry.nbytes)
        self.evictions = 0

    def popitem(self) -> tuple[str, CachedPart]:
        self.evictions += 1
        return super().popitem()


@dataclass
class PartCache:
    """LRU of CachedPart bounded by `max_bytes` (an entry larger than the bound is not kept);
    `entries` is the cachetools mapping, key -> CachedPart."""

    max_bytes: int
    entries: _LruBytes = field(init=False)
    hits: int = 0
    misses: int = 0

    def __post_init__(self) -> None:
        self.entries = _LruBytes(self.max_bytes)

    @property
    def nbytes(self) -> int:
        return int(self.entries.currsize)

    @property
    def evictions(self) -> int:
        return self.entries.evictions

    def get(self, key: str, build: Callable[[], CachedPart]) -> tuple[CachedPart, bool]:
        """The entry for `key`, built on a miss; returns `(entry, was_cached)`."""
        entry = self.entries.get(key)
        if entry is not None:
            self.hits += 1
            return entry, True
        self.misses += 1
        entry = build()
        if entry.nbytes <= self.max_bytes:
            self.entries[key] = entry  # least recently used out until it fits
        return entry, False

    def stats(self) -> dict:
        return {
            "entries": len(self.entries),
            "bytes": self.nbytes,
            "max_bytes": self.max_bytes,
            "hits": self.hits,
            "misses": self.misses,
            "evictions": self.evictions,
        }


def file_key(path: str | Path, salt: str = "") -> str:
    """SHA-256 of a file's bytes (and `salt`, e.g. the sampling settings)."""
    digest = hashlib.sha256(salt.encode())
    try:
        with Path(path).open("rb") as fh:
            for chunk in iter(lambda: fh.read(1 << 20), b""):
                digest.update(chunk)
    except OSError as err:
        raise PathcheckError(f"cannot read part: {err.strerror}", path=path, code="part") from err
    return digest.hexdigest()


def json_key(data: Any, salt: str = "") -> str:
    """SHA-256 of a JSON value in canonical form (sorted keys), and `salt`."""
    text = json.dumps(data, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256((salt + text).encode()).hexdigest()


def deep_nbytes(obj: Any, depth: int = 6, _seen: set[int] | None = None) -> int:
    """Approximate memory held by numpy arrays reachable from `obj` (attributes, sequences,
    dicts), bytes."""
    seen = _seen if _seen is not None else set()
    if id(obj) in seen or depth < 0:
        return 0
    seen.add(id(obj))
    if isinstance(obj, np.ndarray):
        return int(obj.nbytes)
    if isinstance(obj, str | bytes | int | float | bool) or obj is None:
        return 0
    if isinstance(obj, dict):
        children = list(obj.values())
    elif isinstance(obj, list | tuple | set | frozenset):
        children = list(obj)
    else:
        children = [getattr(obj, name) for name in _attribute_names(obj)]
    return sum(deep_nbytes(c, depth - 1, seen) for c in children)


def _attribute_names(obj: Any) -> list[str]:
    names = list(getattr(obj, "__dict__", {}))
    for cls in type(obj).__mro__:
        slots = cls.__dict__.get("__slots__", ())
        names.extend([slots] if isinstance(slots, str) else slots)
    return [n for n in names if hasattr(obj, n)]
