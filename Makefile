# Every target creates .venv on first use and installs the project into it.
PYTHON ?= python3.11
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: report test bench derive clean

$(STAMP): pyproject.toml
	test -d $(VENV) || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[crosscheck,vtk,test,sweep]"
	touch $(STAMP)

report: $(STAMP)
	$(BIN)/flexmbs report

test: $(STAMP)
	$(BIN)/python -m pytest -q

bench: $(STAMP)
	$(BIN)/flexmbs bench

derive: $(STAMP)
	$(BIN)/flexmbs derive

clean:
	rm -rf $(VENV) .pytest_cache
