# On a fresh Debian machine (root or sudo) these set up what they need and then:
#   make demo    simulate the default scene headless, write mesh/image/metrics
#   make check   lint (ruff) and run the fast tests, a few minutes (docs/testing.md)
#   make test    lint and run the whole test suite, slow simulations included (CI)
PYTHON ?= python3
OUT ?= out/demo
SUDO := $(shell [ "$$(id -u)" = "0" ] || echo sudo)
APT_PACKAGES := libvulkan1 mesa-vulkan-drivers libusb-1.0-0 libgl1 libegl1 xvfb xdotool
STAMP := .make/setup.stamp

.PHONY: setup demo check test lint bench validate clean

setup: $(STAMP)

$(STAMP): pyproject.toml Makefile
	@missing=$$(for p in $(APT_PACKAGES); do dpkg -s $$p >/dev/null 2>&1 || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	  echo "installing system packages: $$missing"; \
	  $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq $$missing; \
	fi
	$(PYTHON) -m pip install -q -e ".[dev]"
	@mkdir -p .make && touch $(STAMP)

demo: setup
	$(PYTHON) -m sandbox demo --out $(OUT)

lint: setup
	$(PYTHON) -m ruff check .
	$(PYTHON) -m ruff format --check .

# The fast tier: every test not marked slow (unit tests, formulas, finite differences,
# parsing, bad input), in one process.
check: lint
	$(PYTHON) -m pytest -q --durations=10 -m "not slow" tests

# The whole suite in two processes, each printing its 10 slowest tests:
# - tests/test_app.py drives the GUI: GGUI windows on Vulkan (in child processes) under
#   Xvfb and xdotool. It runs in a process of its own so that the simulation tests never
#   share one with GUI and Vulkan state (a GGUI window that outlives a Taichi reset crashes
#   the next test that allocates fields).
# - everything else shares one process and one float64 Taichi runtime; tests/conftest.py
#   renews that runtime between modules before Taichi's 512 field trees run out (past
#   them Taichi segfaults).
test: lint
	$(PYTHON) -m pytest -q --durations=10 --ignore=tests/test_app.py tests
	$(PYTHON) -m pytest -q --durations=10 tests/test_app.py

validate: setup
	$(PYTHON) -m sandbox validate cantilever

bench: setup
	$(PYTHON) benchmarks/bench_step.py

clean:
	rm -rf .make out build *.egg-info
