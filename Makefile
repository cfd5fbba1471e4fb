# The two commands a newcomer needs: `make demo` and `make test`.
# Each creates or refreshes .venv from pyproject.toml first.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test lint typecheck pytest browser bench docs clean

$(STAMP): pyproject.toml
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	@touch $(STAMP)

demo: $(STAMP)
	$(BIN)/aida-kb demo --out demo-output

test: $(STAMP) lint typecheck browser pytest

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

typecheck: $(STAMP)
	$(BIN)/mypy

# The report test opens report.html in headless Chromium: installed here when missing and
# we are root with apt-get (CI, a fresh container); otherwise say how to get it.
browser:
	@if [ -z "$$AIDA_KB_CHROMIUM" ] && ! command -v chromium >/dev/null 2>&1 && ! command -v chromium-browser >/dev/null 2>&1; then \
	    if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	        echo "installing Chromium for the report test (apt-get)"; \
	        apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null; \
	    else \
	        echo "make test needs Chromium for the report test: apt-get install chromium (Debian), or set AIDA_KB_CHROMIUM" >&2; exit 1; \
	    fi; \
	fi

# One worker per core (pytest-xdist); each worker's numpy and OpenCV keep to one thread, so that
# two workers on two cores do not each start a pool of threads that wait on the other's.
pytest: $(STAMP)
	OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 $(BIN)/pytest -q -n auto

bench: $(STAMP)
	@for b in benchmarks/*.py; do echo "== $$b"; $(BIN)/python $$b || exit 1; done

docs: $(STAMP)
	$(BIN)/python -m aida_kb.diagnostics.docs

clean:
	rm -rf $(VENV) .mypy_cache .pytest_cache .ruff_cache build dist
