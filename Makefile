# polishpath — two commands on a fresh machine with Python 3.11+:
#   make demo   create .venv, install, run the main job on the built-in hemisphere into out/
#   make test   create .venv, install with test extras, run the whole test suite
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
OUT    ?= out
# pytest-xdist workers for `make test`: auto = one per CPU the process may use; 0 = no workers (one process)
TEST_WORKERS ?= auto

.PHONY: demo test test-blas venv install install-test system-deps bench clean

# The pip that comes with Python 3.11+ installs the package (editable installs need pip >= 21.3),
# so a fresh venv is not upgraded first (that was ~8 s of network look-ups on every fresh checkout).
$(BIN)/python:
	@$(PYTHON) -c 'import sys; assert sys.version_info >= (3, 11), "polishpath needs Python 3.11 or newer, found " + sys.version.split()[0]'
	$(PYTHON) -m venv $(VENV)

venv: $(BIN)/python

# The editable install follows src/ by itself, so pip runs again only when the package's metadata
# (pyproject.toml, the version) is newer than the last install: a pip run that changes nothing
# still takes ~12 s (it builds the editable wheel), which every `make demo` and `make test` paid.
# --no-compile: pip does not byte-compile the ~6,900 .py files of the dependencies (11 of its ~29 CPU seconds on a
# fresh venv); Python compiles the ~1,600 modules the job imports at their first import instead (about 2 s once,
# docs/performance.md). `make test`'s install keeps pip's byte-compile: its hundreds of processes import them all.
$(VENV)/.installed: pyproject.toml src/polishpath/_version.py | $(BIN)/python
	$(BIN)/python -m pip install -q --no-compile -e .
	@touch $@

# after `make demo`'s --no-compile install, pip leaves the packages already there as they are: byte-compile them
# here (compileall skips what is compiled), or every test's subprocess compiles its imports where Python may not
# write them (PYTHONDONTWRITEBYTECODE)
$(VENV)/.installed-test: pyproject.toml src/polishpath/_version.py | $(BIN)/python
	$(BIN)/python -m pip install -q -e '.[test]'
	@if [ -f $(VENV)/.installed ]; then $(BIN)/python -m compileall -q -j 0 $(VENV)/lib >/dev/null 2>&1 || true; fi
	@touch $@

install: $(VENV)/.installed

install-test: $(VENV)/.installed-test

# Debian packages the tests need: headless chromium for the browser test (skipped when present or
# not root), and LinuxCNC's standalone interpreter rs274 for tests/test_linuxcnc.py (fetched and
# unpacked into a cache folder, not installed; see scripts/get-linuxcnc.sh).
system-deps:
	@bash scripts/install-system-deps.sh
	@bash scripts/get-linuxcnc.sh

# On a fresh clone numba compiles the job's kernels one after another on one core (80 of the first run's
# ~90 CPU seconds). A small raster job on a second core is through its planner in a few seconds and
# compiles the smoothing, metrics and writer kernels while the demo job is still in the pseudo-random
# planner's; the demo job then loads them from numba's cache (docs/performance.md: its compile 80 -> 60
# CPU s). It is stopped when the demo job ends (what it compiled is kept), and not started on one core.
# It flattens by projection (planar spacing): the demo job compiles the MABF kernels itself at the same
# moment anyway, so the helper skips them and is ~5 s of compile sooner at the writers' kernels.
DEMO_HELPER := plan hemisphere:R=12,triangles=700 --spacing 1 --seed 8 --pattern raster --method projection \
	--spacing-on plane --no-report -q

demo: install
	@w=$$(mktemp -d); h=; \
	if [ "$$(nproc 2>/dev/null || echo 1)" -gt 1 ]; then \
		$(BIN)/polishpath $(DEMO_HELPER) -o "$$w/out" >/dev/null 2>&1 & h=$$!; fi; \
	echo "$(BIN)/polishpath plan hemisphere --spacing 0.5 --seed 1 -o $(OUT)"; \
	$(BIN)/polishpath plan hemisphere --spacing 0.5 --seed 1 -o $(OUT); s=$$?; \
	if [ -n "$$h" ]; then kill -9 $$h 2>/dev/null; wait $$h 2>/dev/null; fi; rm -rf "$$w"; exit $$s

# the suite on every core, each test file on one worker (its module-scoped fixtures built once);
# tests/conftest.py compiles numba's kernels once before the workers start
test: install-test system-deps
	$(BIN)/python -m pytest -q -n $(TEST_WORKERS) --dist loadfile

# the tests that compare against stored references or promise the same bytes, under another OpenBLAS
# kernel than the one it picks for this processor (issue 25: the references hold on any x86-64 machine
# within their stated tolerances); BLAS_CORETYPE=Prescott / Haswell / ... for another one
BLAS_CORETYPE ?= Sandybridge
BLAS_TESTS := tests/test_reference_job.py tests/test_cli_plan.py tests/test_stream_job.py tests/test_post.py \
	tests/test_api.py tests/test_integrator.py tests/test_export.py
test-blas: install-test system-deps
	@OPENBLAS_CORETYPE=$(BLAS_CORETYPE) $(BIN)/python -c 'import numpy, scipy.linalg, threadpoolctl; \
		print("OpenBLAS kernels:", sorted({i.get("architecture") for i in threadpoolctl.threadpool_info()}))'
	OPENBLAS_CORETYPE=$(BLAS_CORETYPE) $(BIN)/python -m pytest -q -n $(TEST_WORKERS) --dist loadfile $(BLAS_TESTS)

# benchmarks use the optional fast sparse Cholesky when it can be built (Debian libsuitesparse-dev);
# bench_first_run.py is not among them: it clones the repository and runs make demo and make test
# there (10-30 min), run it by itself
bench: install-test
	@bash scripts/install-system-deps.sh --fast
	-$(BIN)/python -m pip install -q -e '.[fast]'
	@for b in benchmarks/bench_*.py; do [ $$b = benchmarks/bench_first_run.py ] && continue; \
		echo "== $$b"; $(BIN)/python $$b || exit 1; done

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache .hypothesis
