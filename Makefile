# pathcheck: `make demo` sets up and runs the main job on a bundled sample;
# `make test` sets up and runs the whole test suite.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: setup demo test lint bench clean

setup: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e ".[test]"
	touch $(STAMP)

# exit 1 from the check means "findings", which is what the demo job shows
demo: setup
	mkdir -p out
	PATHCHECK_STORE=out/results.sqlite $(BIN)/pathcheck samples/compressor/compressor_small_d12.apt \
		--json out/compressor_d12.json -o out/compressor_d12.nc; test $$? -le 1
	PATHCHECK_STORE=out/results.sqlite $(BIN)/pathcheck report --out out/report.html

test: setup
	bash tools/test-setup.sh
	$(BIN)/ruff check checker postproc tests benchmarks samples
	$(BIN)/python -m pytest -q

lint: setup
	$(BIN)/ruff check checker postproc tests benchmarks samples

bench: setup
	$(BIN)/python -m benchmarks.run_all

clean:
	rm -rf $(VENV) out .pytest_cache
