# Two set-up commands work on a fresh machine: `make demo` and `make test`.
# Both build a venv for one Blender version (pinned requirements/blender-X.txt, real PyPI bpy)
# and the headless-GL system packages first. BLENDER picks the version: 4.5, 5.0 (default), 5.2.
BLENDER ?= 5.0
VENV    := $(if $(filter 5.0,$(BLENDER)),.venv,.venv-$(BLENDER))
PY      := $(VENV)/bin/python
REQS    := requirements/blender-$(BLENDER).txt
STAMP   := $(VENV)/.installed
FILE    ?=
JOBS    ?= 2

.PHONY: test test-matrix demo bench extension sysdeps clean

$(REQS):
	@echo "error: Blender $(BLENDER) has no environment here (supported: 4.5, 5.0, 5.2)" >&2; exit 2

$(STAMP): $(REQS)
	@bash .ci/sysdeps.sh
	rm -rf $(VENV)
	"$$(bash .ci/python_for.sh $(BLENDER))" -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -r $(REQS)
	@touch $(STAMP)

test: $(STAMP)
	$(PY) -m pytest -n $(JOBS) tests

# Every Blender version CI covers, one after another (what .ci/run does).
test-matrix:
	$(MAKE) test BLENDER=5.0
	$(MAKE) test BLENDER=4.5
	$(MAKE) test BLENDER=5.2

demo: $(STAMP)
	$(PY) -m addon demo $(if $(FILE),--file $(FILE),)

bench: $(STAMP)
	$(PY) -m bench

extension: $(STAMP)
	bash .ci/build_extension.sh $(PY)

sysdeps:
	@bash .ci/sysdeps.sh

clean:
	rm -rf .venv .venv-* out dist .pytest_cache
