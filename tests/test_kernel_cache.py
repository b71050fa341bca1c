"""The kernel cache follows the sources: numba checks a cached kernel against the text of its
own file only, so a kernel that calls a kernel of another file keeps that one's old code when
only the other file changes. The cache folder is keyed by a hash of all the sources
(`checker.kernel_cache.source_key`): shown here with real numba on a two-file package, whose
caller's answer follows the callee's edit only because the folder changed."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
import textwrap

import pytest

from checker.kernel_cache import runs_portable, source_key

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
    from checker.kernel_cache import kernel_cache_dir

    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv("PATHCHECK_CACHE_DIR", str(tmp_path))
    assert kernel_cache_dir() == tmp_path / "numba" / source_key()
    assert len(source_key()) == 12


def test_only_the_newest_versions_kernels_are_kept(tmp_path):
    from checker.kernel_cache import KEEP_VERSIONS, prune_versions

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
    from checker.kernel_cache import kernels_compiled
    from checker.engine.grid.rotations import rotate_rows

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
                        ignore=shutil.ignore_patterns("__pycache__", "kernels"))
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
    assert any(cached.glob("rotations._rotate_indexed-*.nbi"))


def _install(tmp_path, name: str):
    """A copy of the package at tmp_path/name (as a wheel installs it), without kernels."""
    import shutil

    import checker

    root = tmp_path / name
    shutil.copytree(os.path.dirname(checker.__file__), root / "checker",
                    ignore=shutil.ignore_patterns("__pycache__", "kernels"))
    return root


def _rotate(root, tmp_path, **env_vars) -> list[str]:
    """Run _ROTATE with the package at `root`, pathcheck's environment cleared: the kernels it
    compiled (its answer checked)."""
    drop = ("NUMBA_CACHE_DIR", "NUMBA_CACHE_LOCATOR_CLASSES", "NUMBA_CPU_NAME",
            "NUMBA_CPU_FEATURES", "PATHCHECK_CACHE_DIR", "PATHCHECK_KERNELS")
    env = {k: v for k, v in os.environ.items() if k not in drop}
    env.update(PYTHONPATH=str(root), **env_vars)
    done = subprocess.run([sys.executable, "-c", _ROTATE], capture_output=True, text=True,
                          env=env, timeout=300, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    where, answer = done.stdout.split(" ", 1)
    assert where.startswith(str(root))
    points, compiled = answer.rsplit("] ", 1)
    assert points == "[[-2.0, 1.0, 3.0]"
    return ast.literal_eval(compiled.strip())


@pytest.mark.skipif(not runs_portable(), reason="this CPU does not run the portable kernels")
def test_portable_kernels_shipped_in_the_package_serve_a_new_cache_until_warm(tmp_path):
    """`make wheel` compiles the kernels for numba's generic CPU into resources/kernels with a
    stamp of the sources they serve; an install's first process seeds its new cache folder
    with them and loads them (compiling nothing) until `pathcheck warm` has marked the folder
    (cache.HOST_MARK): then it compiles for this CPU, which the portable kernels do not serve."""
    from checker.kernel_cache import HOST_MARK, PORTABLE_STAMP, portable_stamp

    build = _install(tmp_path, "build")
    shipped = tmp_path / "shipped"
    assert _rotate(build, tmp_path, NUMBA_CACHE_DIR=str(shipped),
                   PATHCHECK_KERNELS="portable") == ["_rotate_indexed"]
    (shipped / PORTABLE_STAMP).write_text(portable_stamp() + "\n")
    user = _install(tmp_path, "user")
    (shipped).rename(user / "checker" / "resources" / "kernels")
    cache = tmp_path / "cache"
    assert _rotate(user, tmp_path, PATHCHECK_CACHE_DIR=str(cache)) == [], "compiled again"
    folder = cache / "numba" / source_key()
    assert (folder / PORTABLE_STAMP).is_file()
    (folder / HOST_MARK).touch()
    assert _rotate(user, tmp_path, PATHCHECK_CACHE_DIR=str(cache)) == ["_rotate_indexed"]
    assert _rotate(user, tmp_path, PATHCHECK_CACHE_DIR=str(cache)) == []


def test_portable_kernels_of_other_sources_or_for_other_cpus_are_not_used(tmp_path, monkeypatch):
    """Shipped kernels stamped for other sources (or another numba, Python or CPU) neither seed
    a new folder nor make the process compile for the portable CPU; nor do kernels for the
    right sources on a CPU without AVX2 (its /proc/cpuinfo flags)."""
    from checker import kernel_cache

    shipped = tmp_path / "kernels"
    (shipped / "checker").mkdir(parents=True)
    (shipped / "checker" / "k.nbi").write_text("x")
    monkeypatch.setattr(kernel_cache, "resource", lambda *parts: tmp_path.joinpath(*parts))
    for var in ("PATHCHECK_KERNELS", "NUMBA_CPU_NAME", "NUMBA_CPU_FEATURES"):
        monkeypatch.delenv(var, raising=False)
    flags = "flags\t\t: " + " ".join(sorted(kernel_cache._V3_FLAGS)) + " sse2\n"
    cpuinfo = tmp_path / "cpuinfo"
    runs = kernel_cache.runs_portable
    stamp = kernel_cache.portable_stamp()
    for name, shipped_stamp, cpu_flags, portable in (
            ("other-sources", "0123456789ab" + stamp[12:], flags, False),
            ("other-cpu", stamp.replace(kernel_cache.PORTABLE_CPU, "generic"), flags, False),
            ("no-avx2", stamp, flags.replace(" avx2", ""), False),
            ("these", stamp, flags, True)):
        (shipped / kernel_cache.PORTABLE_STAMP).write_text(shipped_stamp + "\n")
        cpuinfo.write_text("processor\t: 0\n" + cpu_flags)
        monkeypatch.setattr(kernel_cache, "runs_portable", lambda: runs(cpuinfo))
        folder = tmp_path / name
        kernel_cache._seed(folder)
        assert (folder / "checker" / "k.nbi").is_file() == (shipped_stamp == stamp)
        kernel_cache._choose_kernels(folder)
        assert os.environ.pop("PATHCHECK_KERNELS") == ("portable" if portable else "host")
        expected_cpu = kernel_cache.PORTABLE_CPU if portable else None
        assert os.environ.pop("NUMBA_CPU_NAME", None) == expected_cpu
        assert os.environ.pop("NUMBA_CPU_FEATURES", None) == ("" if portable else None)
