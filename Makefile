# neuraluv: two commands do all the set-up on a fresh machine.
#   make demo   virtual env + install + unwrap the built-in default chart
#   make test   virtual env + install + the whole test suite (notebooks included)
PY      ?= python3
VENV    ?= .venv
BIN     := $(VENV)/bin
STAMP   := $(VENV)/.installed
MIRROR  ?= ../shared/data/meshes
export NEURALUV_DATA ?= $(CURDIR)/.cache/neuraluv-data
export MPLBACKEND ?= Agg
export PYVISTA_OFF_SCREEN ?= true

.PHONY: install demo test test-fast data lint clean

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/pip install --quiet torch==2.13.0
	$(BIN)/pip install --quiet -e ".[test]"
	touch $(STAMP)

install: $(STAMP)

demo: install
	$(BIN)/neuraluv demo -o demo_out

# Import the real meshes from a local mirror when there is one (hash-checked).
data: install
	@if [ -d "$(MIRROR)" ]; then $(BIN)/python data_scripts/fetch.py --from "$(MIRROR)"; \
	else echo "no mirror at $(MIRROR): tests that need real meshes will skip"; fi

test: install data
	$(BIN)/python -m pytest -q
	@if ls notebooks/*.ipynb >/dev/null 2>&1; then $(BIN)/python -m pytest -q --nbval-lax notebooks; fi

test-fast: install
	$(BIN)/python -m pytest -q -x

clean:
	rm -rf $(VENV) .cache demo_out .pytest_cache
