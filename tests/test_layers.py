"""The packages depend one way: the layers contracts of pyproject.toml (import-linter, which
counts function-level imports and indirect chains) are kept by the code; the first names every
module of `checker` (`checker.postproc` among them) and is broken by an import that goes up
(checker.postproc -> checker.check), the second every stage of the check (`checker.check`) and
is broken by a stage that imports a later one (the advice importing the document)."""

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


def _layer_modules(which: int = 0) -> list[str]:
    """The modules the layers of contract `which` name (0: the packages, 1: the check's
    stages)."""
    from importlinter.api import read_configuration

    contract = read_configuration(str(REPO / "pyproject.toml"))["contracts_options"][which]
    names = []
    for layer in contract["layers"]:
        names += [n.strip().strip("()") for n in re.split(r"[|:]", layer)]
    return names


def test_the_layers_contract_is_kept():
    run = _lint(REPO)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "2 kept, 0 broken" in run.stdout


def test_the_contract_names_every_module_once():
    names = _layer_modules()
    assert len(names) == len(set(names))
    top = {f"checker.{p.stem}" for p in (REPO / "checker").iterdir()
           if p.suffix == ".py" and p.stem != "__init__"
           or p.is_dir() and (p / "__init__.py").is_file()}
    assert top - set(names) == set(), "modules in no layer"
    assert "checker.postproc" in names


def test_the_check_contract_names_every_stage_once():
    names = _layer_modules(1)
    assert len(names) == len(set(names))
    stages = {p.stem for p in (REPO / "checker" / "check").glob("*.py") if p.stem != "__init__"}
    assert set(names) == stages


def _lint_with(tmp_path: Path, module: str, code: str) -> subprocess.CompletedProcess:
    """The contracts checked on a copy of the package (in `tmp_path`) with `code` appended to
    its `module` (a path under checker/)."""
    shutil.copytree(REPO / "checker", tmp_path / "checker",
                    ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(REPO / "pyproject.toml", tmp_path)
    changed = tmp_path / "checker" / module
    changed.write_text(changed.read_text() + code)
    return _lint(tmp_path)


def test_an_import_that_goes_up_breaks_the_contract(tmp_path):
    # a function-level import: import-linter sees it as well as a module-level one
    run = _lint_with(tmp_path, "postproc/header.py", "\n\ndef _up():\n    from checker.check "
                     "import check_job\n\n    return check_job\n")
    assert run.returncode == 1, run.stdout + run.stderr
    # both: the stages reach the entry of their package through the post
    assert "0 kept, 2 broken" in run.stdout
    assert "checker.postproc.header -> checker.check" in run.stdout


def test_a_stage_that_imports_a_later_one_breaks_the_check_contract(tmp_path):
    run = _lint_with(tmp_path, "check/advice.py", "\n\ndef _later():\n    from "
                     "checker.check.document import build_document\n\n    return build_document\n")
    assert run.returncode == 1, run.stdout + run.stderr
    assert "1 kept, 1 broken" in run.stdout
    assert "checker.check.advice -> checker.check.document" in run.stdout
