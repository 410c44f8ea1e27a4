# Two quick-start commands: `make demo` and `make test`. Everything else is optional.
PY ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
SYS_PKGS := espeak-ng flite sox
EXTRAS ?= whisper,serve,dev

.PHONY: demo test test-slow test-browser lint setup sysdeps bench clean

$(BIN)/python:
	$(PY) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip

$(VENV)/.installed: pyproject.toml | $(BIN)/python
	$(BIN)/pip install -q -e ".[$(EXTRAS)]"
	touch $@

sysdeps:
	@missing=""; for p in espeak-ng flite sox; do command -v $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = "0" ]; then \
	    echo "installing system packages:$$missing"; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $(SYS_PKGS) >/dev/null; \
	  else \
	    echo "missing system packages:$$missing -- run: sudo apt-get install -y $(SYS_PKGS)"; \
	  fi; \
	fi

setup: sysdeps $(VENV)/.installed

demo: setup
	$(BIN)/siftom demo

test: setup
	$(BIN)/ruff check src tests
	$(BIN)/python -m pytest -q -n 2 -p no:cacheprovider

test-slow: setup
	$(BIN)/python -m pytest -q -m slow

test-browser: setup
	$(BIN)/python -m pytest -q -m browser

lint: setup
	$(BIN)/ruff check src tests

clean:
	rm -rf $(VENV) build *.egg-info
