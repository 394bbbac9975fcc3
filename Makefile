# One target per thing a person does. `make run` and `make test` work on a fresh machine.
PY      ?= python3
VENV    := .venv
BIN     := $(VENV)/bin
STAMP   := $(VENV)/.installed

.PHONY: install run test test-slow bench lint sample clean trial-bank validate

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[test]'
	touch $(STAMP)

install: $(STAMP)

# The main job on the embedded default: the sample vessel, then every stage on sample_logs/ (ingest → windows →
# filter → identify → tune → diagnose → report; those already up to date are skipped); ends with the report's path.
run: $(STAMP)
	$(BIN)/seatune vessel info configs/vessels/sample_osv.yaml
	$(BIN)/seatune run configs/runs/sample.yaml

test: $(STAMP)
	$(BIN)/python -m pytest -q -n 2 --dist loadfile  # two processes, one test file each at a time

test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -m slow  # the 20-seed A2 validation and other long checks

bench: $(STAMP)
	$(BIN)/python -m benchmarks

# Regenerate the committed sample trial from its scenario (deterministic: the seed is in the YAML).
sample: $(STAMP)
	$(BIN)/seatune simulate configs/scenarios/sample_trial.yaml --out sample_logs

# Regenerate the golden key figures (tests/golden/sample_summary.json) that `make test` compares a fresh sample
# run against: after a deliberate change to the physics or the methods, never to make a failing test pass.
.PHONY: golden
golden: $(STAMP)
	$(BIN)/seatune report configs/runs/sample.yaml --force ingest
	$(BIN)/python -m seatune.report.golden runs/sample/summary.parquet tests/golden/sample_summary.json

# Blind-validation trial bank (issue 15): seeded trials from the independent path (seatune/simulate/independent/), bit-identical
# on regeneration. full: 62 trials, ~5 min on 2 cores, ~1.4 GB (not committed); TRIAL_BANK_SUBSET=ci: 4 short trials.
TRIAL_BANK        ?= trial_bank
TRIAL_BANK_SUBSET ?= full
trial-bank: $(STAMP)
	$(BIN)/python -m seatune.simulate.independent.bank --out $(TRIAL_BANK) --subset $(TRIAL_BANK_SUBSET) --workers 2

# seatune on every trial of the bank (seatune batch on Dask), scored against each truth.yaml → validation/
# (bank_summary.parquet, bank_metrics.parquet with issue 15's targets, confusion.parquet, index.html).
validate: $(STAMP)
	@test -f $(TRIAL_BANK)/manifest.yaml || $(MAKE) trial-bank
	$(BIN)/python -m seatune.validation --bank $(TRIAL_BANK) --out validation --workers 2

lint: $(STAMP)
	$(BIN)/ruff check seatune tests benchmarks

clean:
	rm -rf $(VENV) .pytest_cache .hypothesis build *.egg-info
