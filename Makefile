# Two commands do everything on a fresh Debian machine (root or sudo):
#   make demo   set up, simulate the default scene headless, write mesh/image/metrics
#   make test   set up, lint (ruff) and run the whole test suite
PYTHON ?= python3
OUT ?= out/demo
SUDO := $(shell [ "$$(id -u)" = "0" ] || echo sudo)
APT_PACKAGES := libvulkan1 mesa-vulkan-drivers libusb-1.0-0 libgl1 libegl1 xvfb xdotool
STAMP := .make/setup.stamp

.PHONY: setup demo test lint bench validate clean

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

test: lint
	$(PYTHON) -m pytest -q --durations=10 tests/test_[a-l]*.py
	$(PYTHON) -m pytest -q --durations=10 tests/test_[m-z]*.py

validate: setup
	$(PYTHON) -m sandbox validate cantilever

bench: setup
	$(PYTHON) benchmarks/bench_step.py

clean:
	rm -rf .make out build *.egg-info
