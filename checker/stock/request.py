"""What a caller asks of the stock check: the stock, the fixtures, the model's resolution and
where the stock is written. The CLI, the service and batch all build one of these."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field

from checker.errors import PathcheckError
from checker.toml_load import read_toml, validated

FOLDER_FILE = "pathcheck-stock.toml"  # a batch folder's stock and fixtures


@dataclass(frozen=True)
class StockRequest:
    """`stock` the `--stock` text (`checker.stock.spec`; None: no stock), `fixtures` the
    `--fixture` texts (`FILE[@RX,RY,RZ,DX,DY,DZ]`, `checker.stock.fixtures`), `resolution` the
    ray spacing (mm; None: `checker.stock.removal.default_resolution` of the stock's size),
    `stock_out` a folder for the stock after each operation and at the end (STL),
    `deviation_out` a file (.ply, .vtk) for the part with the machined part's deviation,
    `leave` the stock left on the part on purpose (mm; THICK in the CL file, the larger) for
    the comparison with the design (`checker.machined`)."""

    stock: str | None = None
    fixtures: tuple[str, ...] = ()
    resolution: float | None = None
    stock_out: Path | None = None
    deviation_out: Path | None = None
    leave: float = 0.0

    @property
    def asked(self) -> bool:
        """Whether there is anything to check against: a stock or a fixture."""
        return self.stock is not None or bool(self.fixtures)


class _FolderStock(BaseModel):
    model_config = ConfigDict(extra="forbid")

    stock: str | None = Field(None, min_length=1)
    fixtures: list[str] = Field(default_factory=list)
    resolution: float | None = Field(None, ge=0.001, le=100.0)
    machine: str | None = Field(None, min_length=1)
    machine_check: bool = False
    machine_clearance: float | None = Field(None, ge=0.0, le=10000.0)


def _folder_file(job: Path) -> tuple[Path, _FolderStock] | None:
    path = Path(job).parent / FOLDER_FILE
    if not path.is_file():
        return None
    return path, validated(_FolderStock, read_toml(path, what="stock file", code="config"),
                           subject="stock file", code="config", path=path)


@dataclass(frozen=True)
class FolderMachine:
    """The machine check a batch folder asks (`machine_check = true` or `machine_clearance`):
    `machine` a shipped name or a machine file (a path inside the folder; None: the job's
    own), `clearance` mm (None: the default), `file` the folder's file."""

    machine: str | None
    clearance: float | None
    file: Path


def folder_machine(job: Path) -> FolderMachine | None:
    """The machine check of the jobs of a folder (`pathcheck-stock.toml`'s `machine`,
    `machine_check`, `machine_clearance`), or None when it asks none."""
    found = _folder_file(job)
    if found is None:
        return None
    path, got = found
    if not got.machine_check and got.machine_clearance is None:
        return None
    machine = got.machine
    if machine is not None and (path.parent / machine).is_file():
        machine = str(path.parent / machine)
    return FolderMachine(machine, got.machine_clearance, path)


def folder_stock(job: Path) -> StockRequest | None:
    """The stock and fixtures of the jobs of a folder (`pathcheck batch`): the file
    `pathcheck-stock.toml` beside the job (`stock = "box:+3"`, `fixtures = ["vise.stl"]`,
    `resolution = 0.1`; files relative to that folder; `folder_machine` reads its machine
    check), or None when there is none."""
    found = _folder_file(job)
    if found is None:
        return None
    path, got = found
    here = path.parent

    def local(text: str) -> str:
        name, at, placement = text.rpartition("@") if "@" in text else (text, "", "")
        inside = here / name if not Path(name).is_absolute() else Path(name)
        return f"{inside}{at}{placement}" if inside.is_file() else text

    stock = got.stock
    if stock is not None and (here / stock).is_file():
        stock = str(here / stock)
    request = StockRequest(stock, tuple(local(f) for f in got.fixtures), got.resolution)
    try:
        _check_texts(request)
    except PathcheckError as err:  # named by the folder's file, where the text was written
        raise PathcheckError(str(err), path=path, code="config") from None
    return request


def _check_texts(request: StockRequest) -> None:
    """The stock's text and the fixtures' files and placements, checked before the run."""
    from checker.stock.fixtures import fixture_placement
    from checker.stock.spec import parse_stock

    if request.stock is not None:
        parse_stock(request.stock)
    for text in request.fixtures:
        fixture_placement(text)
