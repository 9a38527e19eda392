# Every target creates .venv on first use and installs the project into it.
PYTHON ?= python3.11
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: report test fuzz signals bench derive notebooks clean families docs docs-check

$(STAMP): pyproject.toml
	test -d $(VENV) || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[crosscheck,vtk,sweep,test]"
	touch $(STAMP)

$(VENV)/.notebooks: $(STAMP)
	$(BIN)/python -m pip install --quiet -e ".[crosscheck,vtk,sweep,test,notebooks]"
	touch $(VENV)/.notebooks

report: $(STAMP)
	$(BIN)/flexmbs report

# one worker per core (pytest-xdist): most of the suite's time is numba compiling the kernels
test: $(STAMP)
	$(BIN)/python -m pytest -q -n auto

# 10,000 mutated decks through the deck reader, each accepted one run as `flexmbs run` does and its results
# file checked (the test suite runs 1,000, a few steps each)
fuzz: $(STAMP)
	$(BIN)/python tests/fuzz_decks.py --cases 10000 --results

# 20 SIGKILL, 10 SIGTERM/SIGHUP and 20 early Ctrl-C trials of `flexmbs run`: explicit, error-controlled
# generalized-α, arc-length and modes runs in turn; and 4 long-interval trials (explicit, error control)
# (the test suite runs a few)
signals: $(STAMP)
	$(BIN)/python tests/stop_runs.py --kills 20 --terms 10 --ints 20

$(VENV)/.bench: $(STAMP)
	$(BIN)/python -m pip install --quiet -e ".[crosscheck,vtk,sweep,test,bench]"
	touch $(VENV)/.bench

bench: $(VENV)/.bench
	$(BIN)/flexmbs bench

# the element-family verification suite (tests/test_families.py runs meshes 3 and 6): meshes 4 … 32, the order table
families: $(STAMP)
	$(BIN)/python -m flexmbs.verification.families --long

derive: $(STAMP)
	$(BIN)/flexmbs derive

$(VENV)/.docs: $(STAMP)
	$(BIN)/python -m pip install --quiet -e ".[crosscheck,vtk,sweep,test,docs]"
	touch $(VENV)/.docs

# the documentation site → build/docs/index.html: executes the lessons, embeds reports/verification.md
docs: $(VENV)/.docs
	FLEXMBS_DOCS_EXECUTE=1 $(BIN)/python -m sphinx -W --keep-going -b html docs build/docs

# the built site in headless Chromium, offline (needs a Chromium: apt-get install chromium): the index, getting
# started, the deck reference, the API's Domain, formulation §7, lessons 2 and 10 and the HTML report
# (reports/verification.html, written from reports/verification.md when missing) — no raw LaTeX, no console
# error, every 3D view drawn, no broken link or anchor; screenshots of them into build/docs-check/
docs-check: $(VENV)/.docs
	test -f build/docs/index.html || $(MAKE) docs
	$(BIN)/python -m flexmbs.site check build/docs --screenshots build/docs-check --report reports/verification.html

# JupyterLab on the lessons: right-click notebooks/NN_*.py → Open With → Jupytext Notebook
notebooks: $(VENV)/.notebooks
	$(BIN)/jupyter lab --notebook-dir=notebooks

clean:
	rm -rf $(VENV) .pytest_cache
