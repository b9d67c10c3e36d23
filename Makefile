# Every target does its own set-up on a fresh machine.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: test test-fast lint demo bench docs install clean lowest-versions

$(PY):
	$(PYTHON) -m venv $(VENV)

$(STAMP): pyproject.toml | $(PY)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[test]"
	touch $(STAMP)

install: $(STAMP)

test: $(STAMP)
	$(PY) -m pytest -n 2 -q

# everything but the tests marked slow (pyproject.toml [tool.pytest.ini_options] markers)
test-fast: $(STAMP)
	$(PY) -m pytest -n 2 -q -m "not slow"

lint: $(STAMP)
	$(VENV)/bin/ruff check .

# installs every dependency at its lower bound in a temporary venv and runs the fast tests (needs PyPI)
lowest-versions:
	$(PYTHON) benchmarks/lowest_versions.py

demo: $(STAMP)
	$(VENV)/bin/pcs-sindy demo

bench: $(STAMP)
	$(PY) benchmarks/run_all.py

docs: $(STAMP)
	$(PY) docs/build_api.py

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache
