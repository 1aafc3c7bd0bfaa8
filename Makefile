# ur5fault: `make campaign` runs the default fault campaign, `make test` runs the test suite.
# Both create the virtual environment .venv on first use (Python >= 3.10 on PATH as python3).
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: venv test campaign bench lint clean

venv: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev,cluster,ml]'
	touch $(STAMP)

test: $(STAMP)
	$(BIN)/python -m pytest -q

campaign: $(STAMP)
	$(BIN)/ur5fault campaign run campaigns/default.yaml --out results/default

bench: $(STAMP)
	$(BIN)/python bench/bench_speed.py --campaign

lint: $(STAMP)
	$(BIN)/ruff check ur5fault tests bench

clean:
	rm -rf $(VENV) .pytest_cache
