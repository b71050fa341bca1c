"""The allowable-cutter engine: global search with sound pruning, batched local refinement in
(u, v), the thesis's PSO baseline, the advice."""

from checker.engine.api import AllowableResult, allowable

__all__ = ["AllowableResult", "allowable"]
