# Two entry points that work on a fresh machine with only Python: `make demo` and `make test` (the fast tests);
# `make check` runs every test, the slow and the CalculiX ones too.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: demo test check bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	touch $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/frictionid demo --resume --out examples/bolt-m20/out

# the tests on both cores, a test file per worker (module fixtures are built once): the fast ones measured
# 2.0 min instead of 3.7 serially, the slow and CalculiX ones 12.7 min instead of 22.4
test: $(STAMP)
	$(PY) -m pytest -q -n 2 --dist loadfile -m "not slow and not ccx"

check: $(STAMP)
	$(PY) -m pytest -q -n 2 --dist loadfile -m "not slow and not ccx"
	$(PY) -m pytest -q -n 2 --dist loadfile -m "slow or ccx"

bench: $(STAMP)
	$(PY) benchmarks/forward_block2d.py
	$(PY) benchmarks/forward_block3d.py
	$(PY) benchmarks/mortar_block3d.py
	$(PY) benchmarks/condensation.py
	$(PY) benchmarks/identify_block.py
	$(PY) benchmarks/bolt.py
	$(PY) benchmarks/backends.py
	$(PY) benchmarks/blas_threads.py
	$(PY) benchmarks/cli_threads.py
	$(PY) benchmarks/user_mesh.py
	$(PY) benchmarks/full_field.py
	$(PY) benchmarks/frame_fit.py
	$(PY) benchmarks/tightening.py
	$(PY) benchmarks/dask_overhead.py
	$(PY) benchmarks/contact_solves.py
	$(PY) benchmarks/assembly.py

clean:
	rm -rf $(VENV) build src/*.egg-info
