# stiffkit: thin targets over apt-get, pip, meson and pytest.
# On a fresh Debian machine `make test` and `make demo` do everything needed:
# missing Debian packages (apt-get, as root), a project-local .venv, an
# editable install of the package, then the job.

SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
PIP := $(VENV)/bin/pip
STAMP_DEPS := $(VENV)/.deps-stamp
STAMP_INSTALL := $(VENV)/.install-stamp
CHECK_BUILD := build/check
DEB_PACKAGES := gfortran liblapack-dev libopenblas-dev libsuitesparse-dev calculix-ccx tetgen pkg-config python3-venv
PY_BUILD := numpy meson-python meson ninja
PY_RUNTIME := matplotlib meshio gmsh tomli-w yourdfpy pytest hypothesis ruff
# the optional extra `sweep` of pyproject.toml (stiffkit sweep / convergence run on Dask)
PY_SWEEP := 'dask[distributed]>=2024.8' 'tqdm>=4.60'
LINK ?= examples/beam.toml
export OMP_NUM_THREADS ?= 1
export PATH := $(CURDIR)/$(VENV)/bin:$(PATH)

.PHONY: help system-deps venv install test test-core test-py test-slow fuzz test-valgrind lint format demo bench clean link-stiffness convergence sweep
.DEFAULT_GOAL := help

help:
	@echo "stiffkit make targets"
	@echo "  make test        install what is missing, run the Fortran unit tests (-fcheck=all) and pytest"
	@echo "  make fuzz        the property tests (hypothesis) with fresh random examples, FUZZ_FACTOR=5 x as many (~10 min)"
	@echo "  make test-slow   the fine-mesh FEA tests (default beam mesh, accuracy loop; several minutes each)"
	@echo "  make test-valgrind   the Fortran unit tests under valgrind (memory errors, leaks; optional, ~15 s)"
	@echo "  make demo        install what is missing, run the main job on a built-in example"
	@echo "  make bench       benchmarks (figures for the README results section)"
	@echo "  make lint        ruff (lint + format check) and gfortran/gcc warnings as errors"
	@echo "  make format      ruff format + import sorting"
	@echo "  make link-stiffness [LINK=examples/beam.toml]   compliance of a link from its CAD (FEA)"
	@echo "  make convergence [LINK=...] [ORDERS=1,2] [SIZES=5,3,2] [JOBS=2]   mesh-convergence study"
	@echo "  make sweep [LINK=...] VARY='mesh.size=5,3 material.E=7e10,2e11'   design sweep on Dask"
	@echo "  make install     system packages, .venv and an editable install only"
	@echo "  make clean       remove build directories (keeps .venv)"

# Debian packages: installed with apt-get when root, else the command is printed.
system-deps:
	@missing=""; for p in $(DEB_PACKAGES); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "ok installed" || missing="$$missing $$p"; \
	done; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = 0 ]; then \
	    echo "installing Debian packages:$$missing"; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$missing >/dev/null; \
	  else \
	    echo "missing Debian packages; run:  sudo apt-get install -y$$missing"; exit 1; \
	  fi; \
	fi

$(STAMP_DEPS): pyproject.toml | system-deps
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PIP) install -q --upgrade pip
	$(PIP) install -q $(PY_BUILD) $(PY_RUNTIME) $(PY_SWEEP)
	touch $@

venv: system-deps $(STAMP_DEPS)

$(STAMP_INSTALL): $(STAMP_DEPS) meson.build meson.options pyproject.toml
	$(PIP) install -q --no-build-isolation -Cbuild-dir=build/py -e .
	touch $@

install: system-deps $(STAMP_INSTALL)

# Fortran unit tests: the core compiled with -fcheck=all -Wall (meson test()).
test-core: install
	@if [ ! -d $(CHECK_BUILD) ]; then \
	  $(VENV)/bin/meson setup $(CHECK_BUILD) -Dchecks=true -Dbuildtype=debug \
	    -Dpython.install_env=auto >/dev/null; fi
	$(VENV)/bin/meson test -C $(CHECK_BUILD) --print-errorlogs

# The Fortran unit tests under valgrind (optional, not part of `make test`):
# invalid reads/writes, uninitialised values and definite leaks are errors.
VALGRIND := valgrind -q --error-exitcode=1 --leak-check=full --errors-for-leak-kinds=definite --track-origins=yes
test-valgrind: install
	@command -v valgrind >/dev/null || { echo "valgrind is not installed: sudo apt-get install -y valgrind"; exit 1; }
	@if [ ! -d $(CHECK_BUILD) ]; then \
	  $(VENV)/bin/meson setup $(CHECK_BUILD) -Dchecks=true -Dbuildtype=debug \
	    -Dpython.install_env=auto >/dev/null; fi
	$(VENV)/bin/meson test -C $(CHECK_BUILD) --print-errorlogs --timeout-multiplier 20 --wrap='$(VALGRIND)'

test-py: install
	$(PY) -m pytest -q -m "not slow" tests

# Fine-mesh FEA tests (the paper's beam at the default mesh, 116k nodes, and
# the accuracy loop to 0.1 %): several minutes each, so not in `make test`.
test-slow: install
	$(PY) -m pytest -q -m slow tests

test: test-core test-py

# Property tests with fresh random examples (tests/_profiles.py): `make test`
# runs them derandomized (profile "ci": the same examples every run); here
# profile "fuzz" draws new ones, FUZZ_FACTOR times as many. A failure prints
# its reproduction blob and is kept in .hypothesis/ for the next run.
FUZZ_FACTOR ?= 5
FUZZ_TESTS := tests/test_parsers_fuzz.py tests/test_roundtrip.py tests/test_fea_dat.py tests/test_fea_sparse.py \
  tests/test_calib_model.py::test_tool_compliance_symmetric_psd_and_batched_like_single_calls
fuzz: install
	HYPOTHESIS_PROFILE=fuzz STIFFKIT_FUZZ_FACTOR=$(FUZZ_FACTOR) $(PY) -m pytest -q $(FUZZ_TESTS)

# Lint: ruff on the Python, and the Fortran/C core compiled for syntax with
# every warning of the check build turned into an error (in the order of
# core/meson.build, so each module sees the ones it uses).
FORTRAN_LINT := -fsyntax-only -Wall -Wno-maybe-uninitialized -Werror -std=f2008 -ffree-line-length-none
lint: $(STAMP_DEPS)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	@tmp=$$(mktemp -d); trap 'rm -rf "$$tmp"' EXIT; \
	for f in $$(grep -o "'sk_[a-z_]*\.f90'" core/meson.build | tr -d "'"); do \
	  gfortran $(FORTRAN_LINT) -J "$$tmp" core/$$f || exit 1; done; \
	gfortran $(FORTRAN_LINT) -std=f2018 -J "$$tmp" tests/core/sk_testing.f90 || exit 1; \
	gfortran $(FORTRAN_LINT) -std=f2018 -J "$$tmp" tests/core/tree_builder.f90 || exit 1; \
	for f in tests/core/test_*.f90; do gfortran $(FORTRAN_LINT) -std=f2018 -J "$$tmp" $$f || exit 1; done; \
	gcc -fsyntax-only -Wall -Wextra -Werror -std=c11 -I/usr/include/suitesparse core/sk_cholmod.c || exit 1; \
	gcc -fsyntax-only -Wall -Wextra -Werror -std=c11 core/sk_ccxread.c || exit 1; \
	gcc -fsyntax-only -Wall -Wextra -Werror core/sk_ccxio.c; \
	echo "lint: clean"

format: $(STAMP_DEPS)
	$(VENV)/bin/ruff check --fix --select I .
	$(VENV)/bin/ruff format .

demo: install
	$(VENV)/bin/stiffkit demo

bench: install
	$(PY) bench/run.py $(BENCH)

clean:
	rm -rf build $(STAMP_INSTALL)

# FEA link stiffness: one LINK.toml job, and a mesh-convergence study.
ORDERS ?= 1,2
SIZES ?= 5,3,2
JOBS ?= 2
link-stiffness: install
	@mkdir -p out
	$(VENV)/bin/stiffkit link $(LINK) --json out/$(notdir $(basename $(LINK))).json --vtu out/$(notdir $(basename $(LINK))).vtu

convergence: install
	@mkdir -p out
	$(VENV)/bin/stiffkit convergence $(LINK) --orders $(ORDERS) --sizes $(SIZES) -j $(JOBS) \
	  --json out/convergence-$(notdir $(basename $(LINK))).json --png out/convergence-$(notdir $(basename $(LINK))).png

# Design sweep (stiffkit sweep): each word of VARY is one --vary axis.
VARY ?= mesh.size=5,3 material.E=7e10,2e11
sweep: install
	@mkdir -p out
	$(VENV)/bin/stiffkit sweep $(LINK) $(foreach v,$(VARY),--vary '$(v)') \
	  --csv out/sweep-$(notdir $(basename $(LINK))).csv --json out/sweep-$(notdir $(basename $(LINK))).json \
	  --png out/sweep-$(notdir $(basename $(LINK))).png
