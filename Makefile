# polishpath — two commands on a fresh machine with Python 3.11+:
#   make demo   create .venv, install, run the main job on the built-in hemisphere into out/
#   make test   create .venv, install with test extras, run the whole test suite
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
OUT    ?= out

.PHONY: demo test venv install install-test system-deps bench clean

$(BIN)/python:
	@$(PYTHON) -c 'import sys; assert sys.version_info >= (3, 11), "polishpath needs Python 3.11 or newer, found " + sys.version.split()[0]'
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip

venv: $(BIN)/python

install: venv
	$(BIN)/python -m pip install -q -e .

install-test: venv
	$(BIN)/python -m pip install -q -e '.[test]'

# Debian packages the tests need: headless chromium for the browser test (skipped when present or
# not root), and LinuxCNC's standalone interpreter rs274 for tests/test_linuxcnc.py (fetched and
# unpacked into a cache folder, not installed; see scripts/get-linuxcnc.sh).
system-deps:
	@bash scripts/install-system-deps.sh
	@bash scripts/get-linuxcnc.sh

demo: install
	$(BIN)/polishpath plan hemisphere --spacing 0.5 --seed 1 -o $(OUT)

test: install-test system-deps
	$(BIN)/python -m pytest -q

# benchmarks use the optional fast sparse Cholesky when it can be built (Debian libsuitesparse-dev)
bench: install-test
	@bash scripts/install-system-deps.sh --fast
	-$(BIN)/python -m pip install -q -e '.[fast]'
	@for b in benchmarks/bench_*.py; do echo "== $$b"; $(BIN)/python $$b || exit 1; done

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache .hypothesis
