#!/usr/bin/env bash
# The package as a user gets it: build the wheel as `make wheel` does (the portable kernels,
# compiled for LLVM's x86-64-v3 CPU, into a copy of the sources), install it without extras into a
# new venv outside the repository, and from another directory run `pathcheck info` on a sample,
# the first check after the install with an empty cache (timed: it must load the shipped
# kernels, and the compressor job after it compile nothing), `pathcheck warm`, which must find the kernels `make setup` compiled from the repository's
# sources (the same sources: the same cache folder, whatever the install path; none beside the
# installed sources), the demo job and the large compressor job (the kernels' threaded
# variants) in a new process that must then compile nothing (so setup's warm-up, cold on a
# clean machine, covers them, and the installed package loads its kernels), the demo job again
# as `make demo` runs it (check, post with --on-findings stop, report), and a STEP part (which
# must say, in one line, which extra to install). Prints the venv size and the times.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
work=$(mktemp -d "${TMPDIR:-/tmp}/pathcheck-wheel.XXXXXX")
trap 'rm -rf "$work"' EXIT
job="$repo/samples/compressor/compressor_small_d12.apt"
large="$repo/samples/compressor/compressor.apt"

seconds() { printf "%d.%d" $(($1 / 1000000000)) $(($1 % 1000000000 / 100000000)); }
# the sources as git would clone them, the kernels built there, not in the repository (whose
# tests run beside this)
mkdir "$work/src"
(cd "$repo" && tar --exclude=__pycache__ --exclude=checker/resources/kernels -cf - \
    pyproject.toml README.md checker) | tar -xf - -C "$work/src"
start=$(date +%s%N)
(cd "$work/src" && PYTHONPATH="$work/src" "$repo/.venv/bin/python" -m checker.warm \
    --portable checker/resources/kernels) >"$work/portable.log" 2>&1 \
    || { cat "$work/portable.log"; echo "wheel-check: building the portable kernels failed" >&2; exit 1; }
built=$(seconds $(($(date +%s%N) - start)))
"$repo/.venv/bin/python" -m build --wheel --outdir "$work/dist" "$work/src" >"$work/build.log" 2>&1 \
    || { cat "$work/build.log"; exit 1; }
python3 -m venv "$work/venv"
"$work/venv/bin/pip" install --quiet --no-compile "$work"/dist/pathcheck-*.whl >"$work/pip.log" 2>&1 \
    || { cat "$work/pip.log"; exit 1; }
pc="$work/venv/bin/pathcheck"
kernels=$("$repo/.venv/bin/python" -c "from checker.kernel_cache import kernel_cache_dir; print(kernel_cache_dir())")
cd "$work"
export PATHCHECK_STORE="$work/results.sqlite"

"$pc" info "$job" | grep -q "4-axis-Y" || { echo "wheel-check: info failed" >&2; exit 1; }
# the first check after the install, every cache empty: the shipped kernels, nothing compiled
mkdir empty-cache xdg
empty=(env -u NUMBA_CACHE_DIR -u NUMBA_CACHE_LOCATOR_CLASSES -u NUMBA_CPU_NAME -u PATHCHECK_KERNELS
       PATHCHECK_CACHE_DIR="$work/empty-cache" XDG_CACHE_HOME="$work/xdg")
start=$(date +%s%N)
status=0
"${empty[@]}" "$pc" "$job" -o first.nc --json first.json --on-findings stop >first.log 2>&1 || status=$?
first=$(seconds $(($(date +%s%N) - start)))
[ "$status" -eq 1 ] || { cat first.log; echo "wheel-check: first run exit $status, expected 1" >&2; exit 1; }
"${empty[@]}" "$work/venv/bin/python" - "$job" "$large" <<'PY' >first-compiled.log 2>&1 \
    || { cat first-compiled.log; echo "wheel-check: the jobs on the portable kernels failed" >&2; exit 1; }
import sys

from checker.kernel_cache import kernels_compiled
from checker.check.options import CheckOptions
from checker.check import check_job

with kernels_compiled() as compiled:
    for path in sys.argv[1:]:
        check_job(path, options=CheckOptions(output="compiled.nc", on_findings="stop"))
print("compiled:", " ".join(compiled))
PY
[ "$(tail -1 first-compiled.log)" = "compiled: " ] \
    || { cat first-compiled.log; echo "wheel-check: the jobs compiled kernels the wheel should ship" >&2; exit 1; }
start=$(date +%s%N)
"$pc" warm >warm.log 2>&1 || { cat warm.log; echo "wheel-check: warm failed" >&2; exit 1; }
loaded=$(seconds $(($(date +%s%N) - start)))
grep -q "kernels compiled into $kernels " warm.log \
    || { cat warm.log; echo "wheel-check: warm did not use the repository's kernels in $kernels" >&2; exit 1; }
site=$("$work/venv/bin/python" -c "import checker, os; print(os.path.dirname(checker.__file__))")
[ -z "$(find "$site" -name '*.nbi' -not -path "$site/resources/kernels/*")" ] \
    || { echo "wheel-check: kernels cached beside the installed sources in $site" >&2; exit 1; }
# the demo and the large job in a new process, with numba's compile events counted: the warm
# cache serves all
"$work/venv/bin/python" - "$job" "$large" <<'PY' >compiled.log 2>&1 \
    || { cat compiled.log; echo "wheel-check: the jobs after warm failed" >&2; exit 1; }
import sys

from checker.kernel_cache import kernels_compiled
from checker.check.options import CheckOptions
from checker.check import check_job

with kernels_compiled() as compiled:
    for path in sys.argv[1:]:
        check_job(path, options=CheckOptions(output="compiled.nc", on_findings="stop"))
print("compiled:", " ".join(compiled))
PY
[ "$(tail -1 compiled.log)" = "compiled: " ] \
    || { cat compiled.log; echo "wheel-check: the jobs compiled kernels after warm" >&2; exit 1; }
start=$(date +%s%N)
status=0
"$pc" "$job" -o job.nc --json job.json --on-findings stop >check.log 2>&1 || status=$?
warm=$(seconds $(($(date +%s%N) - start)))
[ "$status" -eq 1 ] || { cat check.log; echo "wheel-check: demo exit $status, expected 1" >&2; exit 1; }
"$pc" report -o report.html >/dev/null
for f in job.nc job.json report.html; do
    [ -s "$f" ] || { echo "wheel-check: $f not written" >&2; exit 1; }
done
echo "ISO-10303-21;" >part.step
status=0
"$pc" info part.step >step.out 2>&1 || status=$?
if [ "$status" -ne 2 ] || [ "$(wc -l <step.out)" -ne 1 ] || ! grep -q "pathcheck\[cad\]" step.out; then
    cat step.out; echo "wheel-check: a STEP part without the [cad] extra: exit $status" >&2; exit 1
fi
echo "wheel-check: portable kernels built in $built s; $(basename "$work"/dist/*.whl)" \
     "($(du -h "$work"/dist/*.whl | cut -f1)) installed without extras ($(du -sh "$work/venv" | cut -f1) venv);" \
     "FIRST RUN after the install with an empty cache (the demo job, portable kernels): $first s;" \
     "the compressor job then compiling nothing; from $work: warm $loaded s (the repository's kernels, $kernels), the demo and the compressor job compiling nothing, the demo again $warm s; STEP without [cad]: $(cat step.out)"
