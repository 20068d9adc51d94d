# Two commands do all the set-up: `make demo` and `make test`.
# Each installs what is missing (Debian packages, the .venv, the glTF validator)
# and is quick when it is already there.

PYTHON ?= python3.11
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
NODE_TOOLS := tools/node_modules/gltf-validator/package.json tools/node_modules/three/package.json
APT_STAMP := .venv-apt.stamp

# Shared libraries that open3d (libusb), bpy and vtk/pyvista (X11, GL, EGL) load on Debian 12.
APT_PACKAGES := libusb-1.0-0 libegl1 libgl1 libglx0 libopengl0 libsm6 libice6 libx11-6 \
	libxext6 libxfixes3 libxi6 libxkbcommon0 libxrender1 libxt6 libxxf86vm1 \
	libfontconfig1 libfreetype6 libgomp1
# The database page's browser test drives Debian's chromium through its chromedriver.
APT_PACKAGES += chromium chromium-driver

.PHONY: demo test setup clean

demo: setup
	$(VENV)/bin/homemodel build examples/kitchen --out build/kitchen --force

test: setup
	$(VENV)/bin/lint-imports
	$(PY) -m pytest -q --durations=15

setup: $(APT_STAMP) $(STAMP) $(NODE_TOOLS)

$(APT_STAMP): Makefile
	@missing=$$(for p in $(APT_PACKAGES); do dpkg -s $$p >/dev/null 2>&1 || echo $$p; done); \
	command -v npm >/dev/null || missing="$$missing nodejs npm"; \
	if [ -n "$$missing" ]; then \
		echo "installing Debian packages: $$missing"; \
		if [ "$$(id -u)" = 0 ]; then SUDO=; else SUDO=sudo; fi; \
		$$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq -o DPkg::Lock::Timeout=600 $$missing; \
	fi
	@touch $@

$(STAMP): setup.cfg pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[dev]'
	@touch $@

$(NODE_TOOLS) &: tools/package.json
	npm install --prefix tools --no-audit --no-fund --silent
	@touch $(NODE_TOOLS)

clean:
	rm -rf $(VENV) $(APT_STAMP) tools/node_modules build
