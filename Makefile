# Two entry points: `make demo` (the whole job) and `make test` (the default test suite).
# Each creates .venv when it is missing and installs the package with its pinned builds.

PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.nnda-installed
DEMO   ?= demo
SEED   ?= 0

.PHONY: demo test test-slow bench install clean chromium lint

install: $(STAMP)

$(STAMP): pyproject.toml constraints.txt
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -c constraints.txt -e '.[dev]'
	touch $(STAMP)

# generate the presets, train GD and LM, compare the trackers on S1-S6, write the report (prints its path)
demo: $(STAMP)
	$(BIN)/nnda demo --out $(DEMO) --seed $(SEED)

test: $(STAMP) chromium lint
	$(BIN)/python -m pytest -q

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

test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -m slow

bench: $(STAMP)
	for b in benchmarks/bench_*.py; do $(BIN)/python $$b || exit 1; done

clean:
	rm -rf $(VENV) $(DEMO) .pytest_cache
