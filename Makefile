# Two commands do all the set-up: `make demo` and `make test`.
# Each installs what is missing (Debian packages, the .venv, the glTF validator)
# and is quick when it is already there.

PYTHON ?= python3.11
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
NODE_TOOLS := tools/node_modules/gltf-validator/package.json tools/node_modules/three/package.json
APT_STAMP := .venv-apt.stamp

# Shared libraries that open3d (libusb), bpy, vtk/pyvista and MuJoCo's renderer (X11, GL, EGL)
# load on Debian 12; `ign sdf -k` (ignition-tools with SDFormat 12's libsdformat-dev) checks
# the SDF exports.
APT_PACKAGES := libusb-1.0-0 libegl1 libgl1 libglx0 libopengl0 libsm6 libice6 libx11-6 \
	libxext6 libxfixes3 libxi6 libxkbcommon0 libxrender1 libxt6 libxxf86vm1 \
	libfontconfig1 libfreetype6 libgomp1 \
	ignition-tools libsdformat-dev
# Wait for a lock another apt-get holds (apt prints "Waiting for cache lock") instead of failing.
APT_WAIT := -o DPkg::Lock::Timeout=600
APT_LOCKS := /var/lib/dpkg/lock-frontend /var/lib/dpkg/lock /var/lib/apt/lists/lock
# The database page's browser test drives Debian's chromium through its chromedriver.
APT_PACKAGES += chromium chromium-driver
# The extension's window tests (panels drawn, a background job run from its timer) run in
# Debian's Blender 3.4 under xvfb: the bpy module has no window (about 300 MB).
APT_PACKAGES += blender xvfb

.PHONY: demo test durations setup clean addon addon-screenshots

demo: setup
	$(VENV)/bin/homemodel build examples/kitchen --out build/kitchen --force

# Tests run on one worker more than cores (pytest-xdist `-n auto`, tests/conftest.py), a test
# file per worker at a time, the longest files first by their measured wall time
# (tests/durations.json): a file's module fixtures are made once, and the costly session
# fixtures are shared through tests/fixture_cache.py (in the user's cache, across runs).
# Bytecode caches are written (into .venv and the gitignored __pycache__ folders) even where
# PYTHONDONTWRITEBYTECODE is set: uv installs no .pyc, and without them every worker and every
# child process compiles numpy, scipy, trimesh, scikit-learn... from source again (collecting
# the suite: 26 CPU-s against 8-12; five CLI-heavy test files: 113 CPU-s against 64).
# The tests' scratch folders (pytest's basetemp, the pipelines' staging) go to RAM where /dev/shm
# is a writable tmpfs, as /tmp is on many desktops: every atomic write ends in an fsync, which
# costs about 7 ms on this machine's disk under the suite's load and nothing on tmpfs.
TEST_TMPDIR := $(shell test -d /dev/shm -a -w /dev/shm && mkdir -p /dev/shm/homemodel-tests && echo /dev/shm/homemodel-tests)
PYTEST := env -u PYTHONDONTWRITEBYTECODE $(if $(TEST_TMPDIR),TMPDIR=$(TEST_TMPDIR)) $(PY) -m pytest -q -n auto --dist loadfile --no-loadscope-reorder

test: setup
	env -u PYTHONDONTWRITEBYTECODE $(VENV)/bin/lint-imports
	$(PYTEST) --durations=15

# Each test file's wall seconds, for the order above, measured by a whole suite run on an empty
# fixture cache (the cold time a fresh machine sees) into tests/durations.json. Run it again when
# test files come or their times change much; a file it does not list yet runs first.
DURATIONS_RUN := build/durations
durations: setup
	rm -rf $(DURATIONS_RUN) && mkdir -p $(DURATIONS_RUN)
	HOMEMODEL_TEST_CACHE=$(CURDIR)/$(DURATIONS_RUN)/cache HOMEMODEL_CPU_PROFILE=$(CURDIR)/$(DURATIONS_RUN)/profile.json $(PYTEST)
	$(PY) tests/cpu_profile.py --durations tests/durations.json $(DURATIONS_RUN)/profile.json

setup: $(APT_STAMP) $(STAMP) $(NODE_TOOLS)

$(APT_STAMP): Makefile
	@missing=$$(for p in $(APT_PACKAGES); do dpkg -s $$p >/dev/null 2>&1 || echo $$p; done); \
	command -v npm >/dev/null || missing="$$missing nodejs npm"; \
	if [ -n "$$missing" ]; then \
		echo "installing Debian packages: $$missing"; \
		if [ "$$(id -u)" = 0 ]; then SUDO=; else SUDO=sudo; fi; \
		if command -v fuser >/dev/null && $$SUDO fuser $(APT_LOCKS) >/dev/null 2>&1; then \
			echo "waiting for another apt-get or dpkg (unattended upgrades on a fresh machine?) to release its lock, up to 10 minutes"; \
		fi; \
		$$SUDO apt-get $(APT_WAIT) update -q && \
		$$SUDO env DEBIAN_FRONTEND=noninteractive apt-get $(APT_WAIT) install -y -q $$missing; \
	fi
	@touch $@

# uv installs the same packages as pip from the same index, downloading and unpacking in
# parallel: a fraction of pip's time for the 1.5 GB of wheels. The venv is made without pip
# (ensurepip compiling pip cost 7 CPU-s); the system's pip puts uv into it (ensurepip where
# there is none), and uv installs pip with the rest, for `.venv/bin/pip`.
$(STAMP): setup.cfg pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv --without-pip $(VENV)
	test -x $(VENV)/bin/uv || $(PYTHON) -m pip --python $(PY) install -q 'uv>=0.9,<1' \
		|| { $(PY) -m ensurepip -q && $(PY) -m pip install -q 'uv>=0.9,<1'; }
	$(VENV)/bin/uv pip install -q --python $(PY) -e '.[dev]' pip
	@touch $@

$(NODE_TOOLS) &: tools/package.json
	npm install --prefix tools --no-audit --no-fund --silent
	@touch $(NODE_TOOLS)

# The Blender extension: blender_addons/ zipped by Blender's own extension tool (it ships
# inside the bpy wheel, so no Blender is needed) and checked by its validator.
ADDON_ZIP ?= build/homemodel_addon.zip
BLENDER_EXT = $$($(PY) -c "import glob, sysconfig; print(glob.glob(sysconfig.get_paths()['purelib'] + '/bpy/*/scripts/addons_core/bl_pkg/cli/blender_ext.py')[0])")

addon: setup
	@mkdir -p $(dir $(ADDON_ZIP))
	$(PY) $(BLENDER_EXT) build --source-dir blender_addons --output-filepath $(ADDON_ZIP)
	$(PY) $(BLENDER_EXT) validate $(ADDON_ZIP)

# Screenshots of the extension's panels in a real Blender window (Debian's Blender 3.4 under
# xvfb, which `setup` installs) with the kitchen of `make demo` in the viewport.
addon-screenshots: demo
	blender -b --factory-startup --python-expr "import bpy; bpy.ops.wm.read_factory_settings(use_empty=True); bpy.ops.wm.save_as_mainfile(filepath='$(CURDIR)/build/empty.blend')"
	HOMEMODEL_COMMAND="$(CURDIR)/$(PY) -m homemodel" xvfb-run -a -s "-screen 0 1600x1000x24" \
		blender --factory-startup --enable-event-simulate build/empty.blend \
		--python tools/addon_screenshots.py -- $(CURDIR) build/kitchen/map.xml docs/images

clean:
	rm -rf $(VENV) $(APT_STAMP) tools/node_modules build
