# Two set-up commands work on a fresh machine: `make demo` and `make test`.
# Both build a venv for one Blender version (pinned requirements/blender-X.txt, real PyPI bpy)
# and the headless-GL/Vulkan system packages first. BLENDER picks the version: 4.5, 5.0 (default),
# 5.2, 5.3.
BLENDER ?= 5.0
VENV    := $(if $(filter 5.0,$(BLENDER)),.venv,.venv-$(BLENDER))
PY      := $(VENV)/bin/python
REQS    := requirements/blender-$(BLENDER).txt
STAMP   := $(VENV)/.installed
FILE    ?=
JOBS    ?= 2
# Blender GPU backends `make test` covers (testing/gpu_backend.py reads SPLATLINE_GPU_BACKEND): the
# first runs the whole suite, each further one the tests marked gpu_module (viewport drawing,
# the engine's Blender-GPU path). 5.3 defaults to Vulkan (lavapipe here) and keeps OpenGL;
# 4.5-5.2 default to OpenGL.
GPU_BACKENDS := $(if $(filter 5.3,$(BLENDER)),VULKAN OPENGL,OPENGL)
# The peers, outside tools the peer tests check Splatline against (testing/peers.py), live
# outside the repository: `make peers` (.ci/peers.sh) installs them. Where they are installed,
# their paths reach the tests and the bench; a variable already set in the environment wins.
# Without them peer tests skip, saying why, except under CI (tests/project/test_peers_present.py).
SPLATLINE_PEERS ?= $(HOME)/.cache/splatline-peers
SPLATLINE_SPLAT_TRANSFORM ?= $(wildcard $(SPLATLINE_PEERS)/npm/node_modules/.bin/splat-transform)
SPLATLINE_GSPLAT_JS ?= $(patsubst %/gsplat,%,$(wildcard $(SPLATLINE_PEERS)/npm/node_modules/gsplat))
SPLATLINE_GS3D_JS ?= $(patsubst %/@mkkellogg,%,$(wildcard $(SPLATLINE_PEERS)/npm/node_modules/@mkkellogg))
SPLATLINE_OPENJD ?= $(wildcard $(SPLATLINE_PEERS)/openjd/bin/openjd)
export SPLATLINE_PEERS SPLATLINE_SPLAT_TRANSFORM SPLATLINE_GSPLAT_JS SPLATLINE_GS3D_JS SPLATLINE_OPENJD

.PHONY: test test-matrix demo bench extension sysdeps peers clean

$(REQS):
	@echo "error: Blender $(BLENDER) has no environment here (supported: 4.5, 5.0, 5.2, 5.3)" >&2; exit 2

$(STAMP): $(REQS)
	@bash .ci/sysdeps.sh
	rm -rf $(VENV)
	"$$(bash .ci/python_for.sh $(BLENDER))" -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -r $(REQS)
	@touch $(STAMP)

# sysdeps each time: a venv built before a system package joined the list gets it too.
# Every backend runs even when one fails (which backend a failure belongs to is worth
# knowing); the exit status is the first failure's.
test: sysdeps $(STAMP)
	@rc=0; first=1; for b in $(GPU_BACKENDS); do \
	  if [ $$first = 1 ]; then sel=; else sel="-m gpu_module"; fi; first=0; \
	  echo "SPLATLINE_GPU_BACKEND=$$b $(PY) -m pytest -n $(JOBS) $$sel tests"; \
	  SPLATLINE_GPU_BACKEND=$$b $(PY) -m pytest -n $(JOBS) $$sel tests || { r=$$?; [ $$rc != 0 ] || rc=$$r; }; \
	done; exit $$rc

# Every Blender version CI covers, one after another (what .ci/run does).
test-matrix:
	$(MAKE) test BLENDER=5.0
	$(MAKE) test BLENDER=4.5
	$(MAKE) test BLENDER=5.2
	$(MAKE) test BLENDER=5.3

demo: $(STAMP)
	$(PY) -m addon demo $(if $(FILE),--file $(FILE),)

bench: $(STAMP)
	$(PY) -m bench

extension: $(STAMP)
	bash .ci/build_extension.sh $(PY)

sysdeps:
	@bash .ci/sysdeps.sh

peers:
	@bash .ci/peers.sh >/dev/null

clean:
	rm -rf .venv .venv-* out dist .pytest_cache
