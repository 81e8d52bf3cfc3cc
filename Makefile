# geocontact: every target installs what it needs into .venv on a fresh clone.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: demo test lint bench examples clean

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip

$(STAMP): pyproject.toml | $(PY)
	$(PY) -m pip install -q -e ".[fem,campaign,seismic,test]"
	touch $(STAMP)

lint: $(STAMP)
	$(VENV)/bin/ruff check src tests benchmarks

test: $(STAMP) lint
	$(VENV)/bin/pytest -q

demo: $(STAMP)
	$(VENV)/bin/geocontact demo --out out/demo

bench: $(STAMP)
	$(PY) benchmarks/run.py

# Regenerate the shipped illustrative parameter files (never edited by hand).
examples: $(STAMP)
	$(PY) -m geocontact.law.illustrative --material reference --out examples/params-illustrative.json
	$(PY) -m geocontact.law.illustrative --material reference-weak --out examples/params-illustrative-weak.json

clean:
	rm -rf $(VENV) build out .pytest_cache .ruff_cache
