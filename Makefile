# Two entry points: `make demo` (the whole job) and `make test` (the default test suite).
# `make test-cpus` runs that suite again as on machines with other CPUs (CI runs both).
# Each creates .venv when it is missing and installs the package with its pinned builds.

PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.nnda-installed
DEMO   ?= demo
SEED   ?= 0

.PHONY: demo test test-cpus test-slow bench install clean chromium lint docs docs-check

install: $(STAMP)

$(STAMP): pyproject.toml constraints.txt
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -c constraints.txt -e '.[dev]'
	touch $(STAMP)

# generate the presets, train GD and LM, compare the trackers on S1-S6, write the report (prints its path)
demo: $(STAMP)
	$(BIN)/nnda demo --out $(DEMO) --seed $(SEED)

test: $(STAMP) chromium lint docs-check
	$(BIN)/python -m pytest -q

# the documentation site (mkdocs.yml) into site/; open site/index.html
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --quiet
	@echo "documentation written to site/; open site/index.html"

# the site built in strict mode into a scratch directory: a broken link, a missing page or API object, or
# any other warning fails it (the pages' examples run in tests/test_docs.py)
docs-check: $(STAMP)
	@tmp="$$(mktemp -d)" && trap 'rm -rf "$$tmp"' EXIT && \
	  NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --quiet --site-dir "$$tmp"

# ruff, and the layer contract of shared/design/architecture.md (pyproject.toml, [tool.importlinter])
lint: $(STAMP)
	$(BIN)/ruff check --quiet src tests benchmarks
	$(BIN)/lint-imports --no-cache

# The report's browser test needs Debian's chromium: installed here when missing and possible
# (root with apt-get); otherwise that test is skipped and says why.
chromium:
	@command -v chromium >/dev/null 2>&1 || { [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1 && \
	  echo "installing Debian's chromium for the report's browser test" && apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null; } || \
	  echo "chromium not available: the report's browser test will be skipped"

# The default suite twice more, as on machines with other CPUs: with OpenBLAS choosing its
# kernels itself (OPENBLAS_CORETYPE and OPENBLAS_L2_SIZE unset), then with numpy's SIMD dispatch cut to
# its baseline by disabling every dispatch target numpy was built with and this CPU has (x86_64: X86_V3,
# X86_V4, ...; aarch64: ASIMDHP, SVE, ...), asked at run time: numpy refuses to disable a baseline one.
NPY_DISPATCHED := import numpy._core._multiarray_umath as m; \
  print(" ".join(f for f in m.__cpu_dispatch__ if m.__cpu_features__.get(f)))

# The documentation's examples (tests/test_docs.py, ~3 min) run once, in `make test`: they check the pages
# against the commands, not the arithmetic.
CPU_PYTEST := $(BIN)/python -m pytest -q --ignore=tests/test_docs.py

test-cpus: $(STAMP) chromium
	env -u OPENBLAS_CORETYPE -u OPENBLAS_L2_SIZE $(CPU_PYTEST)
	@features="$$(env -u NPY_DISABLE_CPU_FEATURES $(BIN)/python -c '$(NPY_DISPATCHED)')" && \
	  echo "NPY_DISABLE_CPU_FEATURES=\"$$features\" $(CPU_PYTEST)" && \
	  NPY_DISABLE_CPU_FEATURES="$$features" $(CPU_PYTEST)

test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -m slow

bench: $(STAMP)
	for b in benchmarks/bench_*.py; do $(BIN)/python $$b || exit 1; done

clean:
	rm -rf $(VENV) $(DEMO) site .pytest_cache
