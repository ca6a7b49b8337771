# Two commands do everything on a fresh machine: `make compare` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
# Where `make compare` writes: ignored by git, so a run never dirties the checkout. The committed example
# report is reports/quick/, regenerated on purpose with `make example`.
RESULTS := results/quick

.PHONY: test lint compare example install clean

# (Re)install when the virtualenv is missing or pyproject.toml changed. The filter hides setuptools'
# "Editable installation" notice (a box about folders named like the package: not a problem here).
$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	PYTHONWARNINGS="ignore:Editable installation" $(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)
	@echo "installed: run $(BIN)/bwbench, or activate the environment first: . $(BIN)/activate"

install: $(STAMP)

# one test process per core, up to 4 (pytest-xdist; work stealing: a few tests take 20-35 s)
test: $(STAMP)
	$(BIN)/python -m pytest -n auto --maxprocesses=4 --dist worksteal

# ruff (pyflakes, isort, bugbear) and ruff's formatter over the code and the tests, mypy over src/ and
# optimizers/.
lint: $(STAMP)
	$(BIN)/ruff check src optimizers tests benchmarks studies examples
	$(BIN)/ruff format --check src optimizers tests benchmarks studies examples
	$(BIN)/mypy

# exit 1 = some runs failed (listed): the report still shows the study, failures included
compare: $(STAMP)
	$(BIN)/bwbench compare --config studies/quick.toml --db $(RESULTS)/study.sqlite || test $$? -eq 1
	$(BIN)/bwbench report --db $(RESULTS)/study.sqlite --out $(RESULTS)

# The committed example report (reports/quick/): the same study, rewritten in place.
example: $(STAMP)
	$(BIN)/bwbench compare --config studies/quick.toml --db reports/quick/study.sqlite || test $$? -eq 1
	$(BIN)/bwbench report --db reports/quick/study.sqlite --out reports/quick

clean:
	rm -rf $(VENV) build *.egg-info
