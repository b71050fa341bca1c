"""The kernel cache follows the sources: numba checks a cached kernel against the text of its
own file only, so a kernel that calls a kernel of another file keeps that one's old code when
only the other file changes. The cache folder is keyed by a hash of all the sources
(`checker.cache.source_key`): shown here with real numba on a two-file package, whose caller's
answer follows the callee's edit only because the folder changed."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

from checker.cache import source_key

_CALLEE = "import numba\n\n@numba.njit(cache=True)\ndef f(x):\n    return x + {}\n"
_CALLER = textwrap.dedent("""
    import numba
    from pkg.callee import f

    @numba.njit(cache=True)
    def g(x):
        return f(x) * 10
""")


def _answer(root, cache_dir) -> int:
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir), PYTHONPATH=str(root))
    done = subprocess.run([sys.executable, "-c", "from pkg.caller import g; print(g(1))"],
                          capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stderr
    return int(done.stdout)


def test_a_callers_kernel_follows_its_callees_edit_only_with_the_source_key(tmp_path):
    pkg = tmp_path / "src" / "pkg"
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "caller.py").write_text(_CALLER)
    (pkg / "callee.py").write_text(_CALLEE.format(1))
    fixed = tmp_path / "one-folder"
    before = source_key(pkg)
    assert _answer(tmp_path / "src", fixed) == 20
    assert _answer(tmp_path / "src", tmp_path / before) == 20
    (pkg / "callee.py").write_text(_CALLEE.format(2))
    after = source_key(pkg)
    assert after != before and source_key(pkg) == after
    assert _answer(tmp_path / "src", fixed) == 20, "numba alone keeps the caller's old code"
    assert _answer(tmp_path / "src", tmp_path / after) == 30


def test_the_kernels_are_cached_per_version_of_the_sources(tmp_path, monkeypatch):
    from checker.cache import kernel_cache_dir

    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv("PATHCHECK_CACHE_DIR", str(tmp_path))
    assert kernel_cache_dir() == tmp_path / "numba" / source_key()
    assert len(source_key()) == 12


def test_only_the_newest_versions_kernels_are_kept(tmp_path):
    from checker.cache import KEEP_VERSIONS, prune_versions

    for age in range(KEEP_VERSIONS + 2):
        folder = tmp_path / f"v{age}"
        (folder / "sub").mkdir(parents=True)
        (folder / "sub" / "k.nbi").write_text("x")
        os.utime(folder, (1e9 - age * 100, 1e9 - age * 100))
    (tmp_path / "note.txt").write_text("not a version")
    prune_versions(tmp_path)
    assert sorted(f.name for f in tmp_path.iterdir()) == [
        "note.txt", *(f"v{age}" for age in range(KEEP_VERSIONS))]


_ROTATE = textwrap.dedent("""
    import numpy as np

    import checker
    from checker.cache import kernels_compiled
    from checker.engine.grid.frames import rotate_rows

    q = np.array([[[0.0, -1, 0], [1, 0, 0], [0, 0, 1]]])
    with kernels_compiled() as compiled:
        p = rotate_rows(q, np.array([[1.0, 2, 3]]), np.array([0]))
    print(checker.__file__, p.tolist(), compiled)
""")


def test_a_kernel_compiled_in_one_install_serves_another_install_of_the_same_sources(tmp_path):
    """The cache folder of a kernel is its file's place in the package (kernel_locator.py),
    not the absolute folder numba would hash: a second copy of the package elsewhere (a wheel
    in a venv, another checkout) loads what the first compiled."""
    import shutil

    import checker

    package = os.path.dirname(checker.__file__)
    runs = []
    for name in ("first", "second"):
        shutil.copytree(package, tmp_path / name / "checker",
                        ignore=shutil.ignore_patterns("__pycache__"))
        env = {k: v for k, v in os.environ.items()
               if k not in ("NUMBA_CACHE_DIR", "NUMBA_CACHE_LOCATOR_CLASSES")}
        env.update(PYTHONPATH=str(tmp_path / name), PATHCHECK_CACHE_DIR=str(tmp_path / "cache"))
        done = subprocess.run([sys.executable, "-c", _ROTATE], capture_output=True, text=True,
                              env=env, timeout=300, cwd=tmp_path)
        assert done.returncode == 0, done.stderr
        runs.append(done.stdout.split(" ", 1))
    (first_file, first), (second_file, second) = runs
    assert first_file.startswith(str(tmp_path / "first"))
    assert second_file.startswith(str(tmp_path / "second"))
    assert first == "[[-2.0, 1.0, 3.0]] ['_rotate_indexed']\n"
    assert second == "[[-2.0, 1.0, 3.0]] []\n", "the second install compiled again"
    cached = tmp_path / "cache" / "numba" / source_key() / "checker" / "engine" / "grid"
    assert any(cached.glob("frames._rotate_indexed-*.nbi"))
