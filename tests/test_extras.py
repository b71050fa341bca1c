"""A missing optional dependency is one line naming the extra to install: STEP/IGES parts
without OpenCASCADE ([cad]), a Dask cluster without distributed ([dask])."""

from __future__ import annotations

import subprocess
import sys

import pytest

from checker.errors import PathcheckError
from checker.extras import require


def test_require_names_the_extra():
    with pytest.raises(PathcheckError) as err:
        require("pathcheck_no_such_module", "cad", "reading STEP parts")
    assert str(err.value) == ("reading STEP parts needs the optional 'cad' dependencies "
                              "(pathcheck_no_such_module is not installed): "
                              "pip install 'pathcheck[cad]'")
    assert err.value.code == "extra"


@pytest.mark.parametrize(("blocked", "command", "extra"), [
    ("OCP", ["info", "{tmp}/part.step"], "cad"),
    ("OCP", ["info", "{tmp}/part.igs"], "cad"),
    ("distributed", ["batch", "{tmp}", "--scheduler", "tcp://127.0.0.1:1"], "dask"),
])
def test_cli_without_an_extra_is_one_line_and_exit_2(tmp_path, blocked, command, extra):
    """The module is hidden from the process (None in sys.modules makes its import fail)."""
    (tmp_path / "part.step").write_text("ISO-10303-21;\n")
    (tmp_path / "part.igs").write_text("S      1\n")
    (tmp_path / "job.apt").write_text("CUTTER/6,3\nGOTO/0,0,0\n")
    script = (f"import sys; sys.modules[{blocked!r}] = None; "
              "from checker.cli import main; main(sys.argv[1:])")
    args = [a.format(tmp=tmp_path) for a in command]
    run = subprocess.run([sys.executable, "-c", script, *args], capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 2, run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and f"pip install 'pathcheck[{extra}]'" in lines[0], run.stderr
