# Two targets do all the set-up on a fresh machine (Python 3.11 and make):
#   make demo   install, then run the main job on the bundled sample -> results/demo/
#   make test   install with the test extras, then run the whole test suite
#   make docs   build the documentation into docs/_build/html
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV   ?= .venv
BIN    := $(VENV)/bin
RESULTS ?= results/demo

.PHONY: demo test docs bench samples clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(VENV)/.installed: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e .
	touch $@

$(VENV)/.installed-test: pyproject.toml $(VENV)/.installed
	$(BIN)/python -m pip install --quiet -e ".[test]"
	touch $@

demo: $(VENV)/.installed
	MPLBACKEND=Agg $(BIN)/afferent demo --output $(RESULTS) --overwrite

test: $(VENV)/.installed-test
	MPLBACKEND=Agg $(BIN)/python -m pytest -n 2 --durations=15

docs: $(VENV)/.installed-test
	$(BIN)/python -m sphinx -W --keep-going -b html docs docs/_build/html

bench: $(VENV)/.installed-test
	for b in benchmarks/bench_*.py; do MPLBACKEND=Agg $(BIN)/python $$b || exit 1; done

samples: $(VENV)/.installed
	$(BIN)/python -m pip install --quiet -e ".[samples]"
	$(BIN)/python sample_sed/make_samples.py

clean:
	rm -rf $(VENV) results .pytest_cache
