# One-command set-up: every target creates the environment when it is missing.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
DEMO   ?= scenarios/library/greeting.toml
OUT    ?= out
FUZZ   ?= 20

.PHONY: env demo test fuzz lint golden bench clean

env: $(STAMP)

$(STAMP): pyproject.toml requirements.lock
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -r requirements.lock
	$(BIN)/python -m pip install -q --no-deps -e .
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/python -m oimi demo --out $(OUT)

test: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/python -m pytest

# The fuzz suite (also part of `test`) with FUZZ times as many examples per property.
fuzz: $(STAMP)
	OIMI_FUZZ_EXAMPLES=$(FUZZ) $(BIN)/python -m pytest tests/fuzz

lint: $(STAMP)
	$(BIN)/ruff check .

golden: $(STAMP)
	$(BIN)/python -m replay.golden --regenerate

bench: $(STAMP)
	$(BIN)/python -m oimi bench --out docs/bench.json

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache
