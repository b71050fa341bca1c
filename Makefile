# pathcheck: `make demo` sets up and runs the main job on a bundled sample;
# `make test` sets up and runs the whole test suite.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
THREE := checker/resources/vendor/three
THREE_NPM := tools/three/node_modules/three

.PHONY: setup demo test lint bench wheel clean

# The base install, then at once (two cores) the [all] extra (STEP/IGES, Dask, the test tools)
# and the kernels compiled once into the per-user cache (`pathcheck warm`, run from the source
# tree while the extra is installed); three.js (npm) fetched from the start beside both.
# The packages are installed by uv (`UV`), which fetches and links them several times faster than
# pip; the venv gets pip with the extra, for the user.
# $(TIME): a prefix for each step, empty by default (e.g. `make demo TIME="/usr/bin/time -a -o
# F"` appends each step's times to F).
setup: $(STAMP) $(THREE)/VERSION

UV := uv==0.13.9
UV_INSTALL = $(BIN)/uv pip install --quiet --python $(BIN)/python
# uv into the new venv by this Python's pip (22.3 or newer), or else by the venv's own (ensurepip)
$(BIN)/uv:
	$(PYTHON) -m pip --python $(BIN)/python install --quiet --quiet "$(UV)" 2>/dev/null \
		|| { $(BIN)/python -m ensurepip >/dev/null \
			&& $(BIN)/python -m pip install --quiet --quiet "$(UV)"; }
# Python writes the bytecode of what each step imports (the warm-up imports what the commands
# do): where PYTHONDONTWRITEBYTECODE is set (some CI machines) every command would otherwise
# compile numpy, scipy and numba from source again (~1.7 s of start-up)
unexport PYTHONDONTWRITEBYTECODE

# three.js for the 3-D view (`pathcheck view`): the version pinned by tools/three/package-lock.json,
# from the npm registry (no install scripts run), copied with its licence into the package
$(THREE)/VERSION: tools/three/package-lock.json
	cd tools/three && $(TIME) npm ci --ignore-scripts --no-audit --no-fund --silent
	mkdir -p $(THREE)
	cp $(THREE_NPM)/build/three.core.js $(THREE_NPM)/build/three.module.js \
		$(THREE_NPM)/examples/jsm/controls/OrbitControls.js $(THREE_NPM)/LICENSE $(THREE)/
	node -p "require('./$(THREE_NPM)/package.json').version" > $@

$(STAMP): pyproject.toml
	$(MAKE) --no-print-directory $(THREE)/VERSION & three=$$!; \
	$(TIME) $(PYTHON) -m venv --without-pip $(VENV) \
		&& $(TIME) $(MAKE) --no-print-directory $(BIN)/uv \
		&& $(TIME) $(UV_INSTALL) -e . || { wait $$three; exit 1; }; \
	$(TIME) $(UV_INSTALL) -e ".[all]" pip & extra=$$!; \
	$(TIME) $(BIN)/python -m checker.cli warm; warm=$$?; \
	wait $$extra && wait $$three && test $$warm -eq 0
	touch $(STAMP)

# exit 1 from the check means "findings", which is what the demo job shows; the program is
# written with an optional stop (M01) before each offending move (the default refuses it)
demo: setup
	mkdir -p out
	PATHCHECK_STORE=out/results.sqlite $(TIME) $(BIN)/pathcheck samples/compressor/compressor_small_d12.apt \
		--json out/compressor_d12.json -o out/compressor_d12.nc --on-findings stop \
		--view out/compressor_small_d12.view.html; test $$? -le 1
	PATHCHECK_STORE=out/results.sqlite $(TIME) $(BIN)/pathcheck report -o out/report.html

# two processes (the CI machines have two cores; much of the suite is single-threaded:
# subprocesses, sockets, parsing), a test file's tests kept together in one of them; the wheel
# check (mostly one core compiling its kernels cold) beside them, its report after pytest's;
# pytest's status first (exit 5: no tests)
test: setup
	bash tools/test-setup.sh
	$(BIN)/ruff check checker tests benchmarks samples tools
	log=$$(mktemp); bash tools/wheel-check.sh >$$log 2>&1 & wheel=$$!; \
		$(BIN)/python -m pytest -q -n 2 --dist loadfile --durations=15; tests=$$?; \
		wait $$wheel; checked=$$?; cat $$log; rm -f $$log; \
		if [ $$tests -ne 0 ]; then exit $$tests; fi; exit $$checked

lint: setup
	$(BIN)/ruff check checker tests benchmarks samples tools

bench: setup
	$(BIN)/python -m benchmarks.run_all

# the source distribution, then the wheel with the portable kernels of its sources (compiled
# for LLVM's x86-64-v3 CPU (AVX2, FMA) into checker/resources/kernels, not kept in git), in dist/
wheel: setup
	rm -rf dist build checker/resources/kernels
	$(BIN)/python -m build --sdist --outdir dist .
	$(BIN)/python -m checker.warm --portable checker/resources/kernels
	$(BIN)/python -m build --wheel --outdir dist .

clean:
	rm -rf $(VENV) out dist build .pytest_cache checker/resources/kernels \
		checker/resources/vendor tools/three/node_modules
