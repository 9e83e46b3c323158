# Set-up is part of every target: a fresh clone needs only `make run` or `make test`.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
DOCS_STAMP := $(VENV)/.installed-docs

.PHONY: venv run test test-all bench docs clean

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

venv: $(STAMP)

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

# The docs' own dependencies (the `docs` extra) go into the same .venv, on top of `.[test]`.
$(DOCS_STAMP): $(STAMP)
	$(BIN)/python -m pip install --quiet -e '.[docs]'
	touch $(DOCS_STAMP)

# The site into docs/_build/html. -E rereads every page, so a warning is never hidden by an
# earlier build. DOCSFLAGS defaults to CI's: every warning fails the build (-W), all of them
# reported (--keep-going); `make docs DOCSFLAGS=` shows warnings without failing, while writing.
DOCSFLAGS ?= -W --keep-going

docs: $(DOCS_STAMP)
	$(BIN)/sphinx-build -E -q $(DOCSFLAGS) -b html docs docs/_build/html

clean:
	rm -rf $(VENV) build *.egg-info docs/_build
