"""What a caller asks of the stock check: the stock, the fixtures, the model's resolution and
where the stock is written. The CLI, the service and batch all build one of these."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class StockRequest:
    """`stock` the `--stock` text (`checker.stock.spec`; None: no stock), `fixtures` the
    `--fixture` texts (`FILE[@RX,RY,RZ,DX,DY,DZ]`, `checker.stock.fixtures`), `resolution` the
    ray spacing (mm; None: `checker.stock.removal.default_resolution` of the stock's size),
    `stock_out` a folder for the stock after each operation and at the end (STL)."""

    stock: str | None = None
    fixtures: tuple[str, ...] = ()
    resolution: float | None = None
    stock_out: Path | None = None

    @property
    def asked(self) -> bool:
        """Whether there is anything to check against: a stock or a fixture."""
        return self.stock is not None or bool(self.fixtures)
