# One target per thing a person does. `make run` and `make test` work on a fresh machine.
PY      ?= python3
VENV    := .venv
BIN     := $(VENV)/bin
STAMP   := $(VENV)/.installed

.PHONY: install run test test-slow bench lint sample clean

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e '.[test]'
	touch $(STAMP)

install: $(STAMP)

# The main job on the embedded default: the sample vessel and sample_logs/ through ingest → windows →
# filter → identify (later stages extend it to the report).
run: $(STAMP)
	$(BIN)/seatune vessel info configs/vessels/sample_osv.yaml
	$(BIN)/seatune tune configs/runs/sample.yaml
	@echo "artefacts in runs/sample/"

test: $(STAMP)
	$(BIN)/python -m pytest -q

test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -m slow || [ $$? -eq 5 ]  # 5 = no test is marked slow yet

bench: $(STAMP)
	$(BIN)/python -m benchmarks

# Regenerate the committed sample trial from its scenario (deterministic: the seed is in the YAML).
sample: $(STAMP)
	$(BIN)/seatune simulate configs/scenarios/sample_trial.yaml --out sample_logs

lint: $(STAMP)
	$(BIN)/ruff check seatune tests benchmarks

clean:
	rm -rf $(VENV) .pytest_cache .hypothesis build *.egg-info
