"""The packages depend one way: the layers contract of pyproject.toml (import-linter, which
counts function-level imports and indirect chains) is kept by the code, names every module of
`checker` (`checker.postproc` among them), and is broken by an import that goes up
(checker.postproc -> checker.job)."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

from requires import require_extra

require_extra("importlinter", "test")

REPO = Path(__file__).resolve().parents[1]
LINT = "import sys; from importlinter.cli import lint_imports_command; lint_imports_command()"


def _lint(root: Path) -> subprocess.CompletedProcess:
    """`lint-imports` on the tree under `root` (its pyproject.toml, its packages first)."""
    env = {**os.environ, "PYTHONPATH": str(root), "NO_COLOR": "1", "COLUMNS": "200"}
    return subprocess.run([sys.executable, "-c", LINT, "--config", str(root / "pyproject.toml"),
                           "--no-cache"], cwd=root, env=env, capture_output=True, text=True,
                          timeout=300)


def _layer_modules() -> list[str]:
    from importlinter.api import read_configuration

    (contract,) = read_configuration(str(REPO / "pyproject.toml"))["contracts_options"]
    names = []
    for layer in contract["layers"]:
        names += [n.strip().strip("()") for n in re.split(r"[|:]", layer)]
    return names


def test_the_layers_contract_is_kept():
    run = _lint(REPO)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "1 kept, 0 broken" in run.stdout


def test_the_contract_names_every_module_once():
    names = _layer_modules()
    assert len(names) == len(set(names))
    top = {f"checker.{p.stem}" for p in (REPO / "checker").iterdir()
           if p.suffix == ".py" and p.stem != "__init__"
           or p.is_dir() and (p / "__init__.py").is_file()}
    assert top - set(names) == set(), "modules in no layer"
    assert "checker.postproc" in names


def test_an_import_that_goes_up_breaks_the_contract(tmp_path):
    shutil.copytree(REPO / "checker", tmp_path / "checker",
                    ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(REPO / "pyproject.toml", tmp_path)
    header = tmp_path / "checker" / "postproc" / "header.py"
    # a function-level import: import-linter sees it as well as a module-level one
    header.write_text(header.read_text() + "\n\ndef _up():\n    from checker.job import check_job"
                      "\n\n    return check_job\n")
    run = _lint(tmp_path)
    assert run.returncode == 1, run.stdout + run.stderr
    assert "0 kept, 1 broken" in run.stdout
    assert "checker.postproc.header -> checker.job" in run.stdout
