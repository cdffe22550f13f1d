# neuraluv: two commands do all the set-up on a fresh machine.
#   make demo       virtual env + install + unwrap the built-in default chart
#   make test       virtual env + install + the whole test suite: unit tests and doctests,
#                   every notebook once under nbval, the book built from those runs and checked
#   make test-fast  unit tests and doctests of the library, without the slow tier (no notebooks, no
#                   benchmarks, no end-to-end atlases or CLI subprocesses): about a minute
PY      ?= python3
VENV    ?= .venv
BIN     := $(VENV)/bin
STAMP   := $(VENV)/.installed
MIRROR  ?= ../shared/data/meshes
AUTHORED_MIRROR ?= ../shared/data/authored
LAB_ARGS ?=
# Real meshes: `make data` fills neuraluv.datasets.data_dir(), which in a checkout is .cache/neuraluv-data
# (the library's own default there, so Jupyter and pytest started without make find them too);
# a NEURALUV_DATA in the environment overrides both.
export MPLBACKEND ?= Agg
export PYVISTA_OFF_SCREEN ?= true
# OpenBLAS' own threads fight torch's on 2 cores (a 256x256 eigh: 1 s vs 6 ms)
export OPENBLAS_NUM_THREADS ?= 1

.PHONY: gltf-validator install demo test test-fast test-notebooks book book-check data lab blender-env baselines bench-quick reproduce reproduce-quick acceptance atlas-acceptance clean

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/pip install --quiet torch==2.13.0
	$(BIN)/pip install --quiet -e ".[test,docs,render,sweep,fast]"
	touch $(STAMP)

install: $(STAMP)

demo: install
	$(BIN)/neuraluv demo -o demo_out

# Import the real meshes from a local mirror when there is one (sha256-checked) into data_dir().
data: install
	@if [ -d "$(MIRROR)" ]; then $(BIN)/python data_scripts/fetch.py --from "$(MIRROR)"; \
	else echo "no mirror at $(MIRROR): tests that need real meshes will skip"; fi
	@if [ -d "$(AUTHORED_MIRROR)" ]; then $(BIN)/python data_scripts/fetch.py --authored --from "$(AUTHORED_MIRROR)" | tail -1; \
	else echo "no mirror at $(AUTHORED_MIRROR): tests on real authored assets will skip"; fi

test: install data gltf-validator
	$(BIN)/python -m pytest -q
	$(MAKE) test-notebooks
	$(MAKE) book-check

test-fast: install
	$(BIN)/python -m pytest -q -x -m "not slow" tests neuraluv

# The Khronos glTF validator (npm) for the tests that check every GLB they write; without npm they skip.
gltf-validator:
	@if [ -d .cache/node/node_modules/gltf-validator ]; then :; \
	elif command -v npm >/dev/null 2>&1; then mkdir -p .cache/node && cd .cache/node && \
	  (npm install --silent --no-audit --no-fund gltf-validator@2.0.0-dev.3.10 >/dev/null 2>&1 \
	   || echo "npm install gltf-validator failed: the glTF validator checks will skip"); \
	else echo "no npm: the glTF validator checks will skip"; fi

# Every notebook once (nbval); their outputs go to the book's execution cache
# (notebooks/conftest.py), so the book build below does not run them again.
# MPLBACKEND is unset so the kernels' inline figures reach the outputs.
# Without the registry's meshes (no mirror, no download) the chapters stop at their first data cell, by design
# (tests/test_notebooks_without_data.py checks that): they are then skipped here, and so is the book check, saying why.
HAVE_MESHES = $(BIN)/python -c "import sys; from neuraluv.datasets import registry as r; sys.exit(not all(map(r.available, r.REGISTRY)))"
NO_MESHES = echo "the registry's meshes are not all cached (make data needs ../shared/data/meshes or a download):"

test-notebooks: install data
	@if $(HAVE_MESHES); then env -u MPLBACKEND $(BIN)/python -m pytest -q --nbval-lax notebooks; \
	else $(NO_MESHES) "the notebooks, which teach on them, are skipped"; fi

# The Jupyter Book (v1, builds offline); notebooks executed with a cache.
book: install
	$(BIN)/python book/build.py

# Build the book and check it: a page with figures per notebook, the API pages, a Chromium screenshot.
book-check: install
	@if $(HAVE_MESHES); then $(MAKE) book && $(BIN)/python book/check.py; \
	else $(NO_MESHES) "the book build and its check, which need the notebooks' figures, are skipped"; fi

# JupyterLab on the notebooks (as root add LAB_ARGS=--allow-root).
lab: install
	$(BIN)/jupyter lab --ServerApp.root_dir=notebooks $(LAB_ARGS)

# Optional Blender baselines: bpy 4.5 in its own venv (about 370 MB).
blender-env:
	$(PY) -m venv .venv-bpy
	.venv-bpy/bin/pip install --quiet "bpy==4.5.*" numpy
	@echo "export NEURALUV_BPY_PYTHON=$(CURDIR)/.venv-bpy/bin/python"

# Optional external baselines: the BFF command-line tool and OptCuts, built into .cache/third_party/bin
# from ../shared/third_party when present (else cloned from GitHub). OptCuts bundles Triangle:
# research use only (non-commercial). Needs: build-essential cmake libsuitesparse-dev libtbb-dev libglfw3-dev.
baselines:
	sh data_scripts/build_baselines.sh

bench-quick: install data
	$(BIN)/neuraluv bench compact --quick -o .cache/bench-quick

# Every table of the paper in quick mode (tiny budgets, small inputs; minutes): checks that each
# runner works end to end; writes to .cache/reproduce-quick, never to results/.
QUICK_OUT ?= .cache/reproduce-quick
REPRODUCE_BENCHES := compact failure-modes ablation ntk charts pareto speed atlas-quality repair baselines generated
reproduce-quick: install data
	@for b in $(REPRODUCE_BENCHES); do \
	  echo "== neuraluv bench $$b --quick"; \
	  $(BIN)/neuraluv bench $$b --quick --quiet -o $(QUICK_OUT)/$$b || exit $$?; done

# Every table at the paper's settings into results/ (long: days on a 2-core CPU, hours on a GPU;
# resumable: re-running continues from each folder's rows.jsonl). Run from a clean commit:
# every report records the commit and refuses none, but a "+dirty" commit is not a result.
# External baselines: `make baselines` and `make blender-env` first, or their rows say why not.
RESULTS ?= results
reproduce: install data
	@git diff --quiet HEAD -- neuraluv || echo "warning: neuraluv/ has uncommitted changes: the reports will record +dirty"
	$(BIN)/pip install --quiet -e ".[paper]"  # the harness extra: mouette, the repair table's classical anchor
	$(BIN)/neuraluv bench compact --preset paper --resume -o $(RESULTS)/compact
	$(BIN)/neuraluv bench failure-modes --preset paper --resume -o $(RESULTS)/failure-modes
	$(BIN)/neuraluv bench ablation --preset paper --seeds 0 1 2 --resume -o $(RESULTS)/ablation
	$(BIN)/neuraluv bench ntk --full --trajectory -o $(RESULTS)/ntk
	$(BIN)/neuraluv bench charts --preset paper --iterations 1000 --k0 --resume -o $(RESULTS)/charts
	$(BIN)/neuraluv bench pareto --preset paper --budgets 500 750 1000 5000 --sets compact xatlas --resume -o $(RESULTS)/pareto
	$(BIN)/neuraluv bench baselines --optcuts-sample 10 -o $(RESULTS)/baselines
	$(BIN)/neuraluv bench atlas-quality --threads 1 -o $(RESULTS)/atlas
	$(BIN)/neuraluv bench generated --assets 25 --sweep 500 --resume -o $(RESULTS)/generated
	$(BIN)/neuraluv bench repair -o $(RESULTS)/repair
	$(BIN)/neuraluv bench speed -o $(RESULTS)/speed

# Issue-2 acceptance table: paper and fast presets vs SLIM-1k on Camel, Hand, Bob.
acceptance: install data
	$(BIN)/python data_scripts/solver_acceptance.py

# Issue-5 acceptance: atlases of every closed registry mesh, pyvista's meshes, 50 generated assets.
atlas-acceptance: install data
	nice -n 10 $(BIN)/python data_scripts/atlas_acceptance.py

clean:
	rm -rf $(VENV) .cache demo_out .pytest_cache book/_build
