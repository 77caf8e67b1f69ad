# Two entry points for a fresh machine: `make demo` and `make test` (and `make docs`,
# the documentation site, which CI builds too).
# Both create .venv and install oftimg (`make demo` with what the demo needs alone, `make
# test` with the test extras: napari, Qt, vtk, dask), and the system library open3d
# needs (libusb-1.0-0) when `import open3d` fails; `make test` also installs Debian's
# chromium for the HTML report test.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
BASE_STAMP := $(VENV)/.oftimg-base
STAMP  := $(VENV)/.oftimg-installed
DEMO_OUT ?= oftimg-demo
# pytest-xdist processes for the suite, each taking whole test files (their module
# fixtures built once): on 2 cores ~1010 s -> 718 s wall time (2026-12-02; wall times here
# vary by 30 % or more with the machine's load, and the suite has grown since)
TEST_WORKERS ?= 2
# pip without setuptools' "Editable installation" box (a flat layout's editable install
# warns of folders named like the package: this clone's own oftimg/ is that folder)
PIP := PYTHONWARNINGS="ignore:Editable installation" $(PY) -m pip
# pip install, tried three times: a fresh machine's download of a large wheel (open3d,
# 400 MB) can be cut by the network, and pip's own resumes start again at once (CI saw six
# fail in 8 s at the same byte); a pause before trying again is what gets it through
PIP_INSTALL = for try in 1 2 3; do $(PIP) install --quiet $(1) && break; \
	  [ $$try = 3 ] && exit 1; echo "pip install $(1): failed (a network download?); trying again in $$((try * 30)) s"; \
	  sleep $$((try * 30)); done
# apt-get quietly: its ~120 dpkg lines only when it fails
APT_INSTALL = SUDO=$$(command -v sudo >/dev/null && [ "$$(id -u)" != 0 ] && echo sudo); \
	  log=$$(mktemp); { $$SUDO apt-get update -qq && $$SUDO env DEBIAN_FRONTEND=noninteractive \
	  apt-get install -y -qq
APT_DONE = ; } >"$$log" 2>&1 || { cat "$$log"; rm -f "$$log"; exit 1; }; rm -f "$$log"

.PHONY: demo test test-long test-system test-lowest setup clean docs napari lint
setup: $(STAMP)

# oftimg and what it needs to run (the demo's set-up)
$(BASE_STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(call PIP_INSTALL,--upgrade pip)
	$(call PIP_INSTALL,--resume-retries 10 -e .)
	@$(PY) -c "import open3d" 2>/dev/null || { \
	  echo "open3d cannot load libusb-1.0: installing libusb-1.0-0 with apt-get"; \
	  $(APT_INSTALL) libusb-1.0-0 $(APT_DONE); }
	$(PY) -c "import open3d"
	touch $(BASE_STAMP)

# and the test extras
$(STAMP): $(BASE_STAMP)
	$(call PIP_INSTALL,--resume-retries 10 -e '.[test]')
	touch $(STAMP)

# ruff's checks and layout (pyproject.toml [tool.ruff]; .pre-commit-config.yaml runs them
# per commit; ruff format . mends the layout)
lint: $(STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(VENV)/bin/python -m mypy

demo: $(BASE_STAMP)
	$(VENV)/bin/oftimg demo --out $(DEMO_OUT) --overwrite

# what Qt's xcb platform (napari's window under Xvfb) loads besides Qt itself
QT_XCB_LIBS = libxcb-cursor0 libxkbcommon-x11-0 libxcb-icccm4 libxcb-image0 libxcb-keysyms1 \
  libxcb-randr0 libxcb-render-util0 libxcb-shape0 libxcb-xinerama0 libxcb-xkb1

# napari with its Qt, and the system libraries Qt's window needs (Debian / Ubuntu:
# python -m oftimg.napari names them), then the check in one line
napari: $(STAMP)
	$(call PIP_INSTALL,--resume-retries 10 -e '.[napari]')
	@missing=$$($(PY) -m oftimg.napari --packages); [ -z "$$missing" ] || { \
	  echo "napari's window needs $$missing: installing them with apt-get"; \
	  $(APT_INSTALL) $$missing $(APT_DONE); }
	@$(PY) -m oftimg.napari --check || [ -z "$$DISPLAY" ]

# what the tests need besides the Python packages: a headless browser (the report test),
# Qt's system libraries (the napari widget) and a virtual screen (napari's window)
test-system: $(STAMP)
	@command -v chromium >/dev/null || { \
	  echo "the report test needs a headless browser: installing chromium with apt-get"; \
	  $(APT_INSTALL) chromium $(APT_DONE); }
	@$(PY) -c "from qtpy import QtWidgets" 2>/dev/null || { \
	  echo "Qt (the napari widget's tests) cannot load its system libraries: installing them with apt-get"; \
	  $(APT_INSTALL) libgl1 libegl1 libxkbcommon0 libfontconfig1 libdbus-1-3 $(APT_DONE); }
	@command -v xvfb-run >/dev/null || { \
	  echo "napari's window tests need a virtual screen: installing xvfb with apt-get"; \
	  $(APT_INSTALL) xvfb xauth $(QT_XCB_LIBS) $(APT_DONE); }

PYTEST = xvfb-run -a -s "-screen 0 1600x1000x24" $(PY) -m pytest -n $(TEST_WORKERS) \
  --dist loadfile --durations=30
# the gallery's example cohort, made once for the long tests and the docs (.ci/run runs both)
EXAMPLE_CACHE := $(CURDIR)/.cache/oftimg

# the suite but its long tests (~13 min on 2 cores)
test: test-system
	$(PYTEST) -m "not long"

# the long tests: accuracy (a zoo draw of each kind, known motions), rendering (the report in
# a browser, napari's window, the gallery examples) and whole-cohort runs (~15 min on 2 cores)
test-long: test-system
	OFTIMG_CACHE=$(EXAMPLE_CACHE) $(PYTEST) -m long

# The suite against the oldest releases pyproject.toml allows (uv's lowest-direct
# resolution), in .venv-lowest: checks that those lower bounds are true.
test-lowest: $(STAMP)
	test -x $(VENV)/bin/uv || $(PIP) install --quiet uv
	$(VENV)/bin/uv venv --quiet --allow-existing --python $(PY) .venv-lowest
	$(VENV)/bin/uv pip install --quiet --python .venv-lowest/bin/python \
	  --resolution lowest-direct -e '.[test]'
	.venv-lowest/bin/python -m pytest -n $(TEST_WORKERS) --dist loadfile

clean:
	rm -rf $(VENV) .venv-lowest $(DEMO_OUT) .cache

# The documentation site (Sphinx, its gallery executed) into docs/_build/html; warnings
# are errors
docs: $(STAMP)
	$(call PIP_INSTALL,--resume-retries 10 -e '.[docs]')
	OFTIMG_CACHE=$(EXAMPLE_CACHE) $(PY) -m sphinx -W --keep-going -b html docs docs/_build/html
	$(PY) scripts/check_api_reference.py docs/_build/html
