# Two targets do all the set-up on a fresh machine (Python 3.11 and make):
#   make demo   install, then run the main job on the bundled sample -> results/demo/
#   make test   install with the test extras, then run the whole test suite; then, where a Python
#               >= 3.12 is installed, the numerical core's tests on it with the newest numpy and
#               brian2 it takes (make test-newest; numpy is capped below 2.4 only on Python 3.11)
#   make docs   build the documentation into docs/_build/html
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV   ?= .venv
BIN    := $(VENV)/bin
RESULTS ?= results/demo

.PHONY: demo test test-newest docs bench samples clean

# The newest Python >= 3.12 here (on PATH, or installed by pyenv), else empty
ifeq ($(origin NEWEST),undefined)
NEWEST := $(shell for v in 3.14 3.13 3.12; do for p in $$(command -v python$$v) \
	$${PYENV_ROOT:-$$HOME/.pyenv}/versions/$$v*/bin/python$$v; do \
	"$$p" -c "" 2>/dev/null && { echo "$$p"; exit 0; }; done; done)
endif
NEWEST_VENV ?= .venv-newest
# what depends on numpy's and brian2's versions: the engines, the stages, sampling (no extras needed)
NEWEST_TESTS := tests/test_spiking.py tests/test_spiking_exact.py tests/test_zones.py tests/test_brian2_warnings.py \
	tests/test_transduction.py tests/test_synthesis.py tests/test_stimulus.py tests/test_calibration.py \
	tests/test_sampling.py tests/test_pipeline.py tests/test_strain_energy.py tests/test_extremes.py \
	tests/test_profiles.py tests/test_quadratic.py

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
	$(MAKE) --no-print-directory test-newest

$(NEWEST_VENV)/.installed: pyproject.toml
	$(NEWEST) -m venv $(NEWEST_VENV)
	$(NEWEST_VENV)/bin/python -m pip install --quiet --upgrade pip
	$(NEWEST_VENV)/bin/python -m pip install --quiet -e . "pytest>=8" "hypothesis>=6.100" "pytest-xdist>=3.5"
	touch $@

ifeq ($(NEWEST),)
test-newest:
	@echo "make test-newest: no Python >= 3.12 installed here; skipped"
else
test-newest: $(NEWEST_VENV)/.installed
	@$(NEWEST_VENV)/bin/python -c "import sys, numpy, brian2; print('make test-newest: Python', sys.version.split()[0], \
	'numpy', numpy.__version__, 'brian2', brian2.__version__)"
	MPLBACKEND=Agg $(NEWEST_VENV)/bin/python -m pytest -n 2 -p no:cacheprovider $(NEWEST_TESTS)
endif

docs: $(VENV)/.installed-test
	$(BIN)/python -m sphinx -W --keep-going -b html docs docs/_build/html

bench: $(VENV)/.installed-test
	for b in benchmarks/bench_*.py; do MPLBACKEND=Agg $(BIN)/python $$b || exit 1; done

samples: $(VENV)/.installed
	$(BIN)/python -m pip install --quiet -e ".[samples]"
	$(BIN)/python sample_sed/make_samples.py
	$(BIN)/python sample_sed/make_chapter4.py
	$(BIN)/python sample_sed/make_vibration.py
	$(BIN)/python sample_sed/make_samples.py --packaged

clean:
	rm -rf $(VENV) $(NEWEST_VENV) results .pytest_cache
