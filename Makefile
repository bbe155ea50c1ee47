# Two set-up commands work on a fresh machine: `make demo` and `make test`.
# Both build .venv (Python 3.11, pinned requirements) and the headless-GL system packages first.
PYTHON ?= python3.11
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
FILE   ?=
JOBS   ?= 2

.PHONY: test demo bench extension sysdeps clean

$(STAMP): requirements.txt
	@bash .ci/sysdeps.sh
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -r requirements.txt
	@touch $(STAMP)

test: $(STAMP)
	$(PY) -m pytest -n $(JOBS) tests

demo: $(STAMP)
	$(PY) -m addon demo $(if $(FILE),--file $(FILE),)

bench: $(STAMP)
	$(PY) -m bench

extension: $(STAMP)
	bash .ci/build_extension.sh $(PY)

sysdeps:
	@bash .ci/sysdeps.sh

clean:
	rm -rf $(VENV) out dist .pytest_cache
