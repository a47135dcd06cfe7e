# The two commands of the README: `make demo` and `make test` do all set-up from nothing.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
BUILD ?= build/cpp
JOBS ?= 2
OUT ?= out

# The example cases are in examples/. The QP problem sets in ../shared (CI lays it out beside
# the checkout; MPMPP_SHARED_DIR points elsewhere) are optional: their tests skip without them.

.PHONY: all demo test lint test-cpp test-python install system-deps venv sanitize clean

# ccache (a system dependency) lets the package build (build/<wheel tag>) and the test build
# (build/cpp) share their compiled objects: both sit two levels below the checkout, so with
# CCACHE_BASEDIR their compile commands are the same and each source compiles once, not twice.
# Read when a recipe runs (after system-deps), not when make starts.
export CMAKE_CXX_COMPILER_LAUNCHER = $(shell command -v ccache 2>/dev/null)
export CCACHE_BASEDIR = $(CURDIR)

all: test

system-deps:
	bash scripts/system-deps.sh

$(VENV)/bin/python:
	$(PYTHON) -m venv $(VENV)

venv: system-deps $(VENV)/bin/python
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q "scikit-build-core>=0.8" "pybind11>=2.11"

# The package is rebuilt incrementally in build/<wheel tag> on every install; the script shows
# the compiler's progress and works around scikit-build-core's 5 s CMake probe.
install: venv
	bash scripts/install-package.sh $(PY) build/install.log

# The C++ build also puts _core next to python/mpmpp, and pytest imports that build
# (PYTHONPATH=python); MPMPP_BUILD_DIR lets the streaming test run the stream_csv example.
test-cpp: install
	cmake -S . -B $(BUILD) -DMPMPP_BUILD_TESTS=ON -DMPMPP_BUILD_PYTHON=ON -DMPMPP_INPLACE=ON \
	      -DPython_EXECUTABLE=$(abspath $(PY)) -DCMAKE_BUILD_TYPE=Release
	@echo "building the C++ engine and its tests in $(BUILD)"
	cmake --build $(BUILD) -j $(JOBS)
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

# pytest exits 5 when it collects no test; that is not a failure of the suite.
test-python: test-cpp
	PYTHONPATH=python MPMPP_BUILD_DIR=$(abspath $(BUILD)) $(PY) -m pytest -q tests/python || [ $$? -eq 5 ]

test: lint test-cpp test-python

# ruff (config in pyproject.toml) and clang-format (.clang-format) over every source file.
lint: install
	$(VENV)/bin/ruff check python tests bench studies scripts
	clang-format --dry-run --Werror $$(find cpp tests/cpp -name '*.cpp' -o -name '*.hpp' | sort)

demo: install
	$(VENV)/bin/mpmpp demo siso --out $(OUT)/demo-siso

sanitize: system-deps
	cmake -S . -B build/sanitize -DMPMPP_BUILD_TESTS=ON -DMPMPP_SANITIZE=ON -DCMAKE_BUILD_TYPE=Debug
	cmake --build build/sanitize -j $(JOBS)
	cd build/sanitize && ctest --output-on-failure

clean:
	rm -rf build $(VENV) $(OUT)
