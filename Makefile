# Two commands do everything on a fresh machine: `make compare` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: test compare install clean

# (Re)install when the virtualenv is missing or pyproject.toml changed.
$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

install: $(STAMP)

test: $(STAMP)
	$(BIN)/python -m pytest

compare: $(STAMP)
	# exit 1 = some runs failed (listed): the report still shows the study, failures included
	$(BIN)/bwbench compare --config studies/quick.toml --db reports/quick/study.sqlite || test $$? -eq 1
	$(BIN)/bwbench report --db reports/quick/study.sqlite --out reports/quick

clean:
	rm -rf $(VENV) build *.egg-info
