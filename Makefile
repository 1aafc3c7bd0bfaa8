# ur5fault: `make campaign` runs the default fault campaign, `make test` runs the test suite.
# Both create the virtual environment .venv on first use (Python >= 3.10 on PATH as python3).
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: venv test campaign bench lint clean diagnostics prognostics

venv: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev,cluster,ml]'
	touch $(STAMP)

test: $(STAMP)
	$(BIN)/python -m pytest -q

# daily work: everything except the tests marked slow (long physics, campaigns, wheel, discrepancy); about 5 min
.PHONY: test-fast
test-fast: $(STAMP)
	$(BIN)/python -m pytest -q -m "not slow"

campaign: $(STAMP)
	$(BIN)/ur5fault campaign run campaigns/default.yaml --out results/default

bench: $(STAMP)
	$(BIN)/python bench/bench_speed.py --campaign

# issue 11: the diagnostics dataset (campaigns/diagnostics.yaml, 2,000 sampled runs + backlash twins) and its
# benchmark, end to end, timed. Resumes an interrupted run; for a timing from scratch: rm -rf results/diagnostics.
# The target rebuilds the benchmark of the campaign it made: --replace (the command alone refuses an earlier one)
diagnostics: $(STAMP)
	@start=$$(date +%s); \
	$(BIN)/ur5fault campaign run campaigns/diagnostics.yaml --out results/diagnostics --quiet --yes && \
	$(BIN)/ur5fault benchmark results/diagnostics --replace && \
	end=$$(date +%s) && \
	echo "make diagnostics: $$((end - start)) s end to end (campaign + benchmark)" && \
	$(BIN)/python bench/diagnostics_timing.py results/diagnostics --wall-s $$((end - start)) --campaign campaigns/diagnostics.yaml

# issue 20: the prognostics fleet (campaigns/prognostics.yaml, 100 units run to failure) and its RUL benchmark,
# end to end, timed, into results/prognostics/{fleet,benchmark}. Resumes an interrupted fleet. On a shared or
# small machine: PROGNOSTICS=campaigns/prognostics_small.yaml (30 units). The target rebuilds the benchmark of the
# fleet it made: --replace (the twin's radius cache there is kept and extended)
PROGNOSTICS ?= campaigns/prognostics.yaml
prognostics: $(STAMP)
	@start=$$(date +%s); \
	$(BIN)/ur5fault campaign run $(PROGNOSTICS) --out results/prognostics/fleet --quiet --yes && \
	$(BIN)/ur5fault prognose results/prognostics/fleet --out results/prognostics/benchmark --twin --replace && \
	end=$$(date +%s) && \
	echo "make prognostics: $$((end - start)) s end to end (fleet + benchmark)"

lint: $(STAMP)
	$(BIN)/ruff check ur5fault tests bench

clean:
	rm -rf $(VENV) .pytest_cache
