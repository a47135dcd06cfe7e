# The two commands of the README: `make demo` and `make test` do all set-up from nothing.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
BUILD ?= build/cpp
JOBS ?= 2
OUT ?= out

# The example cases and QP problems live in ../shared beside the checkout (CI lays it out so).
# A local clone made elsewhere (git clone . /tmp/x) finds them beside the repository it was
# cloned from; MPMPP_SHARED_DIR, read by ctest's configure step and by pytest, overrides both.
ifeq ($(origin MPMPP_SHARED_DIR),undefined)
  ifeq ($(wildcard ../shared),)
    ORIGIN_SHARED := $(wildcard $(shell git config --get remote.origin.url 2>/dev/null)/../shared)
    ifneq ($(ORIGIN_SHARED),)
      export MPMPP_SHARED_DIR := $(abspath $(ORIGIN_SHARED))
    endif
  endif
endif

.PHONY: all demo test test-cpp test-python install system-deps venv sanitize clean

all: test

system-deps:
	bash scripts/system-deps.sh

$(VENV)/bin/python:
	$(PYTHON) -m venv $(VENV)

venv: system-deps $(VENV)/bin/python
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q "scikit-build-core>=0.8" "pybind11>=2.11"

# The package is rebuilt incrementally in build/<wheel tag> on every install.
install: venv
	$(PY) -m pip install -q --no-build-isolation ".[test]"

# The C++ build also puts _core next to python/mpmpp, and pytest imports that build
# (PYTHONPATH=python); MPMPP_BUILD_DIR lets the streaming test run the stream_csv example.
# (A full pytest run against the installed wheel showed flaky child-process tests in session 1;
# not reinvestigated, see the issue notes.)
test-cpp: install
	cmake -S . -B $(BUILD) -DMPMPP_BUILD_TESTS=ON -DMPMPP_BUILD_PYTHON=ON -DMPMPP_INPLACE=ON \
	      -DPython_EXECUTABLE=$(abspath $(PY)) -DCMAKE_BUILD_TYPE=Release
	cmake --build $(BUILD) -j $(JOBS)
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

# pytest exits 5 when it collects no test; that is not a failure of the suite.
test-python: test-cpp
	PYTHONPATH=python MPMPP_BUILD_DIR=$(abspath $(BUILD)) $(PY) -m pytest -q tests/python || [ $$? -eq 5 ]

test: test-cpp test-python

demo: install
	$(VENV)/bin/mpmpp demo siso --out $(OUT)/demo-siso

sanitize: system-deps
	cmake -S . -B build/sanitize -DMPMPP_BUILD_TESTS=ON -DMPMPP_SANITIZE=ON -DCMAKE_BUILD_TYPE=Debug
	cmake --build build/sanitize -j $(JOBS)
	cd build/sanitize && ctest --output-on-failure

clean:
	rm -rf build $(VENV) $(OUT)
