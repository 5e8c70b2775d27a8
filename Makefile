# One-command set-up: every target creates the environment when it is missing.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
DEV    := $(VENV)/.installed-dev
DEMO   ?= scenarios/library/greeting.toml
OUT    ?= out
FUZZ   ?= 20
SEED   ?=

.PHONY: env dev demo test fuzz soak lint golden bench clean accel

env: $(STAMP)

dev: $(DEV)

$(STAMP): pyproject.toml requirements.lock
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -r requirements.lock
	$(BIN)/python -m pip install -q --no-deps -e .
	$(BIN)/python -m oimi.accel --optional
	touch $(STAMP)

# The hot modules compiled again for their current sources (only those that changed;
# an edited module runs as Python until then). OIMI_PURE=1 runs everything as Python.
accel: $(STAMP)
	$(BIN)/python -m oimi.accel --optional

# The tests' and tools' packages, on top of what oimi itself needs (make demo installs only that).
$(DEV): $(STAMP) requirements-dev.lock
	$(BIN)/python -m pip install -q -r requirements.lock -r requirements-dev.lock
	touch $(DEV)

demo: $(STAMP)
	$(BIN)/python -m oimi demo --out $(OUT)

test: $(DEV)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/python -m pytest

# The fuzz suite (also part of `test`) with FUZZ times as many examples per property; the
# same examples at every run, or others chosen by SEED (make fuzz SEED=7).
fuzz: $(DEV)
	OIMI_FUZZ_EXAMPLES=$(FUZZ) OIMI_FUZZ_SEED=$(SEED) $(BIN)/python -m pytest tests/fuzz \
		$(if $(SEED),--hypothesis-seed=$(SEED))

# The child-safety properties (also part of `test`: every source of motion, sensors failing)
# with FUZZ times as many sessions; SEED as for fuzz.
soak: $(DEV)
	OIMI_FUZZ_EXAMPLES=$(FUZZ) OIMI_FUZZ_SEED=$(SEED) $(BIN)/python -m pytest \
		tests/scenarios/test_safety_property.py $(if $(SEED),--hypothesis-seed=$(SEED))

lint: $(DEV)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

golden: $(STAMP)
	$(BIN)/python -m oimi.replay.golden --regenerate

bench: accel
	$(BIN)/python -m oimi bench --out docs/bench.json

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache
