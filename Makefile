# Two commands for a newcomer: `make demo` and `make test` (each creates its own venv).
PY ?= python3
VENV ?= .venv
# QGIS's Python is Debian's /usr/bin/python3 and needs numpy<2 (see docs/qgis.md); this venv also
# proves the library on numpy 1.26.
QGIS_PY ?= /usr/bin/python3
QVENV ?= .venv-qgis
OUT ?= out
PYTEST_ARGS ?=

.PHONY: demo test test-main test-qgis lint plugin-zip bench clean

$(VENV)/.installed: pyproject.toml
	$(PY) -m venv $(VENV)
	$(VENV)/bin/pip install -q --upgrade pip
	$(VENV)/bin/pip install -q -e ".[test]"
	touch $@

$(QVENV)/.installed: pyproject.toml
	@if $(QGIS_PY) -c "import qgis.core" >/dev/null 2>&1; then \
	  echo "QGIS found: venv from $(QGIS_PY) with system site-packages"; \
	  $(QGIS_PY) -m venv --system-site-packages $(QVENV); \
	else \
	  echo "QGIS not installed: numpy<2 venv from $(PY) (QGIS tests will be skipped)"; \
	  $(PY) -m venv $(QVENV); \
	fi
	$(QVENV)/bin/pip install -q --upgrade pip
	$(QVENV)/bin/pip install -q "numpy<2" "attrs>=24.1" -e ".[test]"
	touch $@

demo: $(VENV)/.installed
	$(VENV)/bin/python -m geoboresight.demo --out $(OUT)

test: test-main test-qgis

test-main: $(VENV)/.installed
	$(VENV)/bin/python -m pytest -m "not qgis" $(PYTEST_ARGS)

test-qgis: $(QVENV)/.installed
	QT_QPA_PLATFORM=offscreen $(QVENV)/bin/python -m pytest $(PYTEST_ARGS)

lint: $(VENV)/.installed
	$(VENV)/bin/ruff check . && $(VENV)/bin/ruff format --check .

bench: $(VENV)/.installed
	for b in benchmarks/*.py; do $(VENV)/bin/python $$b || exit 1; done

clean:
	rm -rf $(VENV) $(QVENV) $(OUT) build dist *.egg-info
