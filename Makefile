# Every target sets up .venv from the project's own files; only python3 is needed.
PY      ?= python3
VENV    := .venv
VPY     := $(VENV)/bin/python
STAMP   := $(VENV)/.installed-$(shell cat pyproject.toml constraints.txt | cksum | cut -d' ' -f1)
export NUMBA_CACHE_DIR ?= $(CURDIR)/.numba_cache
export OMP_NUM_THREADS ?= 1
export OPENBLAS_NUM_THREADS ?= 1
export MKL_NUM_THREADS ?= 1
export MPLBACKEND ?= Agg

.PHONY: venv run test bench bench-koyna verify clean upgrade-deps

$(STAMP): pyproject.toml constraints.txt
	test -x $(VPY) || $(PY) -m venv $(VENV)
	$(VPY) -m pip install --quiet --upgrade pip
	$(VPY) -m pip install --quiet -c constraints.txt -e ".[fe,dev,studies]"
	rm -f $(VENV)/.installed-* && touch $@

venv: $(STAMP)

run: $(STAMP)
	$(VPY) -m ngs_driver run-paper koyna --out results --overwrite
	$(VPY) -m ngs_driver run koyna_engineering --out results/koyna_engineering --overwrite

# both cores: on a fresh clone (cold numba cache) most of the suite is numba compiling the law's
# kernels; one worker per core, each test file on one worker (its fixtures built once).
# tests/conftest.py halves that compile time (numba's inliner; the same machine code) and hands
# out the slowest files first, so that the two workers end together
test: $(STAMP)
	$(VPY) -m pytest -q --benchmark-disable -n 2 --dist loadfile tests

bench: $(STAMP)
	$(VPY) -m pip install --quiet -c constraints.txt -e ".[bench]"
	$(VPY) -m pytest -q tests/bench --benchmark-only --benchmark-json=.benchmarks.json
	$(VPY) verification/write_benchmarks.py
	$(VPY) verification/bench_speed_targets.py
	$(VPY) verification/step_cost.py --duration 4 --parts

# the long Koyna benchmark study (DOF/point scaling, full 10 s runs, OpenSeesPy): ~15 min
bench-koyna: $(STAMP)
	$(VPY) -m pip install --quiet -c constraints.txt -e ".[bench]"
	$(VPY) verification/bench_koyna.py

verify: $(STAMP)
	$(VPY) verification/run_all.py

# the newest versions pyproject.toml allows, the suite run on them, and constraints.txt
# rewritten only when it passes (then commit constraints.txt with the suite's result)
upgrade-deps: $(STAMP)
	$(VPY) -m pip install --quiet --upgrade -e ".[fe,dev,studies]"
	$(VPY) -m pytest -q --benchmark-disable -n 2 --dist loadfile tests
	$(VPY) -m pip freeze --exclude-editable | grep -iv '^dam-seismic' > .constraints.new
	{ sed -n '/^#/p' constraints.txt; cat .constraints.new; } > constraints.txt && rm -f .constraints.new

clean:
	rm -rf $(VENV) .numba_cache verification/out
