# Set-up is part of every target: a fresh clone needs only `make run` or `make test`.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: run test test-all bench clean

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

run: $(STAMP)
	$(BIN)/fogbench suite --out reports

# Two pytest-xdist workers (--dist worksteal: an idle worker takes queued tests from the
# other); tests/conftest.py holds each worker to one BLAS thread. Serially: make test XDIST=
XDIST := -n 2 --dist worksteal

test: $(STAMP)
	$(BIN)/python -m pytest -q -m "not slow" $(XDIST)

test-all: $(STAMP)
	$(BIN)/python -m pytest -q $(XDIST)

bench: $(STAMP)
	$(BIN)/fogbench bench

clean:
	rm -rf $(VENV) build *.egg-info
