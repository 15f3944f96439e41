# The two commands: `make run` serves http://127.0.0.1:8000, `make test` runs the tests.
# Both set everything up on a fresh machine (Debian packages when run as root, the venv).
PYTHON ?= python3
VENV ?= .venv
HOST ?= 127.0.0.1
PORT ?= 8000

.PHONY: run test deps gallery clean

run: $(VENV)/.deps
	$(VENV)/bin/fogbank serve --host $(HOST) --port $(PORT)

test: $(VENV)/.deps
	./scripts/system-deps.sh --test
	$(VENV)/bin/python -m pytest -q

gallery: $(VENV)/.deps
	$(VENV)/bin/fogbank gallery --out docs/gallery --width 1280 --height 720 --repeat 5

deps: $(VENV)/.deps

$(VENV)/.deps: pyproject.toml scripts/system-deps.sh
	./scripts/system-deps.sh
	$(PYTHON) -m venv $(VENV)
	$(VENV)/bin/pip install -q --upgrade pip
	$(VENV)/bin/pip install -q -e '.[test]'
	touch $@

clean:
	rm -rf $(VENV) .pytest_cache .hypothesis
