# Every target sets up .venv from the project's own files; only python3 is needed.
PY      ?= python3
VENV    := .venv
VPY     := $(VENV)/bin/python
STAMP   := $(VENV)/.installed-$(shell cat pyproject.toml | cksum | cut -d' ' -f1)
export NUMBA_CACHE_DIR ?= $(CURDIR)/.numba_cache
export OMP_NUM_THREADS ?= 1
export OPENBLAS_NUM_THREADS ?= 1
export MKL_NUM_THREADS ?= 1
export MPLBACKEND ?= Agg

.PHONY: venv run test bench bench-koyna verify clean

$(STAMP): pyproject.toml
	test -x $(VPY) || $(PY) -m venv $(VENV)
	$(VPY) -m pip install --quiet --upgrade pip
	$(VPY) -m pip install --quiet -e ".[fe,dev,studies]"
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
	$(VPY) -m pip install --quiet -e ".[bench]"
	$(VPY) -m pytest -q tests/bench --benchmark-only --benchmark-json=.benchmarks.json
	$(VPY) verification/write_benchmarks.py
	$(VPY) verification/bench_speed2.py

# the long Koyna benchmark study (DOF/point scaling, full 10 s runs, OpenSeesPy): ~15 min
bench-koyna: $(STAMP)
	$(VPY) -m pip install --quiet -e ".[bench]"
	$(VPY) verification/bench_koyna.py

verify: $(STAMP)
	$(VPY) verification/run_all.py

clean:
	rm -rf $(VENV) .numba_cache verification/out
