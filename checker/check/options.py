"""What a caller asks of a job's check, as one record: the CLI commands, the service, batch runs,
`pathcheck warm` and the tests build one `CheckOptions` and pass it to
`checker.check.check_job` (or `check_toolpath`, `check_program`). Lengths in mm, angles in
degrees (the units of the command line and the service)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from checker.errors import PathcheckError

if TYPE_CHECKING:
    from checker.config import Config
    from checker.cutter import Cutter
    from checker.postproc.machine import Machine
    from checker.stock.request import StockRequest

STRATEGIES = ("allowable", "contact-order")  # the multi-axis planners of `reorient`
ON_FINDINGS = ("refuse", "stop", "comment")  # what posting does with a program that has findings


@dataclass(frozen=True)
class CheckOptions:
    """How a job is checked and where its program goes; every field has the default of
    `pathcheck JOB.apt` without options.

    - `cutter`: a `Cutter` or a "CUTTER/..." statement for every operation (None: each
      operation's own from the CL file), read in `cutter_units` ("mm" or "inch"; None: the
      job's units).
    - `machine`: a machine name, a TOML file or a `Machine` (None: the CL file's
      `PPRINT/MACHINE`, else fanuc-hmc). Multi-axis operations move as its joints move them
      when it has two rotary axes.
    - `config`: a `Config` or a TOML file merged over the defaults (None: the defaults).
    - `b_range`: (lo, hi) degrees, the table angles B searched for 4-axis operations (None:
      the machine's).
    - `reorient`: plan B for 3-axis operations too and re-orient multi-axis ones by `strategy`
      ("allowable": inside the feasible sets, `checker.five_axis.reorient`; "contact-order":
      flat-end and bull-nose cutters at the highest order of contact, Liu et al.,
      `checker.five_axis.contact_plan`).
    - `part_transform`: the part's placement in the CL frame when it was exported in another
      (`checker.geometry.transform`).
    - `stock`: the stock and the fixtures the written program is checked against
      (`checker.stock`; None: none).
    - `machine_clearance`: mm, the least distance between the machine's solids, the tool and
      the work along the written motion (`checker.collide`; None: the machine is not checked).
    - `output`: the G-code file the checked program is posted to (None: not posted), under
      `on_findings` when the program as written has findings ("refuse" writes nothing,
      "stop" a comment and an optional stop M01 before each, "comment" a comment)."""

    cutter: Cutter | str | None = None
    cutter_units: str | None = None
    machine: str | Path | Machine | None = None
    config: Config | str | Path | None = None
    b_range: tuple[float, float] | None = None
    reorient: bool = False
    strategy: str = "allowable"
    part_transform: str | None = None
    stock: StockRequest | None = None
    machine_clearance: float | None = None
    output: str | Path | None = None
    on_findings: str = "refuse"

    def __post_init__(self) -> None:
        if self.strategy not in STRATEGIES:
            raise PathcheckError(f"strategy '{self.strategy}': expected one of "
                                 f"{', '.join(STRATEGIES)}", code="usage")
        if self.on_findings not in ON_FINDINGS:
            raise PathcheckError(f"on_findings '{self.on_findings}': expected one of "
                                 f"{', '.join(ON_FINDINGS)}", code="usage")

    @property
    def to_post(self) -> bool:
        """Whether the checked program is posted (its machine is then resolved even when no
        operation is planned)."""
        return self.output is not None

    @property
    def stock_asked(self) -> bool:
        """Whether the program is checked against a stock or a fixture."""
        return self.stock is not None and self.stock.asked
