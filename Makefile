# Two commands for a newcomer: `make demo` and `make test` (each creates its own venv).
PY ?= python3
VENV ?= .venv
# QGIS's Python is Debian's /usr/bin/python3 and needs numpy<2 (see docs/qgis.md); this venv also
# proves the library on numpy 1.26.
QGIS_PY ?= /usr/bin/python3
QVENV ?= .venv-qgis
OUT ?= out
# The zip a QGIS user installs with "Install from ZIP"; the plugin folder inside is named
# geoboresight_qgis (a folder named geoboresight would shadow the library on QGIS's sys.path).
PLUGIN_ZIP ?= dist/geoboresight-plugin.zip
PYTEST_ARGS ?=
# The version lives in one place, geoboresight/_version.py: pyproject.toml reads it
# (dynamic version) and plugin-zip stamps it into the plugin's metadata.txt.
VERSION := $(shell sed -n 's/^__version__ = "\(.*\)"/\1/p' geoboresight/_version.py)

.PHONY: demo test test-main test-qgis test-qgis-rest lint plugin-zip plugin-repo wheelhouse dist dist-check docs bench validate clean

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
	$(QVENV)/bin/pip install -q "numpy<2" "attrs>=24.1" -e ".[test,docs]"
	@# Debian's matplotlib ships mpl_toolkits as a regular package, which shadows a pip
	@# matplotlib's namespace package (no 3-D axes): then use Debian's matplotlib alone.
	@$(QVENV)/bin/python -c "import matplotlib; matplotlib.use('Agg'); import matplotlib.pyplot as p; p.figure().add_subplot(projection='3d')" 2>/dev/null \
	  || { echo "3-D axes broken by Debian's mpl_toolkits: using Debian's matplotlib"; $(QVENV)/bin/pip uninstall -q -y matplotlib; \
	       $(QVENV)/bin/python -c "import matplotlib; matplotlib.use('Agg'); import matplotlib.pyplot as p; p.figure().add_subplot(projection='3d')"; }
	touch $@

demo: $(VENV)/.installed
	$(VENV)/bin/python -m geoboresight.demo --out $(OUT)

# Every test runs once: all but the QGIS ones with numpy 2 (test-main), the QGIS ones beside
# Debian's QGIS (test-qgis). test-qgis also reruns the modules marked `compat` (their list and
# reasons in tests/conftest.py: what numpy 1.26 or Debian's matplotlib can change); CI
# (.ci/run) adds test-qgis-rest, so that it runs the whole suite in both environments.
test: test-main test-qgis dist-check docs

# The docs extra too: the site's tests read pages through MkDocs' own Markdown extensions.
test-main: $(VENV)/.docs
	$(VENV)/bin/python -m pytest -m "not qgis" $(PYTEST_ARGS)

test-qgis: $(QVENV)/.installed $(VENV)/.installed  # the QGIS tests run .venv/bin/geoboresight as the engine
	QT_QPA_PLATFORM=offscreen $(QVENV)/bin/python -m pytest -m "qgis or compat" $(PYTEST_ARGS)

# The rest of the suite in the QGIS environment (numpy 1.26): with test-qgis, all of it there.
test-qgis-rest: $(QVENV)/.installed $(VENV)/.installed  # some tests build the plugin zip with .venv
	$(QVENV)/bin/python -m pytest -m "not qgis and not compat" $(PYTEST_ARGS)

lint: $(VENV)/.installed
	$(VENV)/bin/ruff check . && $(VENV)/bin/ruff format --check .

# The plugin zip: the plugin folder, LICENSE, metadata.txt with the library's version, the
# operation list (operations.json, from the engine's `engine describe`) so that the tools appear
# before the user has set up an engine, and the library's own wheel (wheels/, pure Python, a
# few hundred kB) that "Set up the geoboresight engine" installs when no field is filled (its
# dependencies then come from the package index). No tests, no sample data.
plugin-zip: $(VENV)/.installed
	@set -e; tmp=$$(mktemp -d); \
	cp -R plugin $$tmp/geoboresight_qgis; \
	find $$tmp -name __pycache__ -prune -exec rm -rf {} +; find $$tmp -name '*.pyc' -delete; \
	cp LICENSE $$tmp/geoboresight_qgis/LICENSE; \
	sed -i 's/^version=.*/version=$(VERSION)/' $$tmp/geoboresight_qgis/metadata.txt; \
	$(VENV)/bin/geoboresight engine describe > $$tmp/geoboresight_qgis/operations.json; \
	$(VENV)/bin/python -m build --wheel --outdir $$tmp/geoboresight_qgis/wheels . > $$tmp/build.log 2>&1 \
	  || { cat $$tmp/build.log; exit 1; }; \
	ls $$tmp/geoboresight_qgis/wheels/geoboresight-$(VERSION)-py3-none-any.whl > /dev/null; \
	mkdir -p "$$(dirname $(PLUGIN_ZIP))"; rm -f $(PLUGIN_ZIP); \
	zip="$$(cd "$$(dirname $(PLUGIN_ZIP))" && pwd)/$$(basename $(PLUGIN_ZIP))"; \
	(cd $$tmp && $(PY) -m zipfile -c "$$zip" geoboresight_qgis); \
	rm -rf $$tmp; echo "wrote $(PLUGIN_ZIP) (QGIS: Plugins > Manage and Install Plugins > Install from ZIP)"

# A QGIS plugin repository: the zip and plugins.xml beside it (what QGIS's plugin manager reads
# from a repository URL). PLUGIN_REPO_URL is where the folder is published; the default, a
# file:// URL of the folder itself, is a repository on this machine.
PLUGIN_REPO ?= dist/plugin-repo
PLUGIN_REPO_URL ?= file://$(abspath $(PLUGIN_REPO))
plugin-repo: plugin-zip
	$(VENV)/bin/python tools/plugin_repo.py $(PLUGIN_ZIP) $(PLUGIN_REPO) --url $(PLUGIN_REPO_URL)

# A wheelhouse for installing the engine offline (or fast, in CI): the library's wheel and
# every dependency's, for the Python that runs the engine (QGIS's on Windows/macOS,
# /usr/bin/python3 here). Give the folder to the setup tool ("Or a folder of wheels") or in
# GEOBORESIGHT_WHEELHOUSE.
WHEELHOUSE ?= dist/wheelhouse
ENGINE_PY ?= $(QGIS_PY)
wheelhouse: $(VENV)/.installed
	$(VENV)/bin/python -m build --wheel --outdir $(WHEELHOUSE) .
	$(VENV)/bin/pip download -q --only-binary :all: -d $(WHEELHOUSE) \
	  --python-version $$($(ENGINE_PY) -c 'import sys; print("%d.%d" % sys.version_info[:2])') \
	  $(WHEELHOUSE)/geoboresight-$(VERSION)-py3-none-any.whl

# The library's wheel and sdist (what the plugin's setup tool installs), version from
# geoboresight/__init__.py.
dist: $(VENV)/.installed
	$(VENV)/bin/python -m build --outdir dist .
	@ls dist/geoboresight-$(VERSION)-*.whl dist/geoboresight-$(VERSION).tar.gz

# The validation on the two scene models, written to one report (validation/REPORT.md; with
# QUICK=1 fewer scenes, into out/validation-quick.md). SECTION=name reruns one section only.
validate: $(VENV)/.installed
	$(VENV)/bin/python -m validation $(if $(QUICK),--quick) $(if $(SECTION),--section $(SECTION))

# The sdist and wheel as they would be published: built without a deprecation warning, and
# passing `twine check --strict` (the metadata PyPI renders).
dist-check: $(VENV)/.installed
	@set -e; tmp=$$(mktemp -d); \
	$(VENV)/bin/python -m build --outdir $$tmp/dist . > $$tmp/build.log 2>&1 || { cat $$tmp/build.log; exit 1; }; \
	if grep -i "deprecat" $$tmp/build.log; then echo "the build warns (above)"; exit 1; fi; \
	$(VENV)/bin/twine check --strict $$tmp/dist/*; rm -rf $$tmp

# The documentation site (site/), offline and strict: a broken link, a public name without a
# docstring or any other warning fails the build. The gallery runs the sample scene.
docs: $(VENV)/.docs
	NO_MKDOCS_2_WARNING=1 $(VENV)/bin/mkdocs build --strict --site-dir site

$(VENV)/.docs: $(VENV)/.installed
	$(VENV)/bin/pip install -q -e ".[test,docs]"
	touch $@

bench: $(VENV)/.installed
	for b in benchmarks/*.py; do $(VENV)/bin/python $$b || exit 1; done

clean:
	rm -rf $(VENV) $(QVENV) $(OUT) build dist site *.egg-info
