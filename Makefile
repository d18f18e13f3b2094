# kinserve: `make demo` and `make test` each work on a fresh machine that has only python3.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
PIP    := $(PY) -m pip
DEMO_OUT ?= demo-out

.PHONY: demo lint test docs bench peers gallery install install-test browser clean

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PIP) install --quiet --upgrade pip

# Stamp files: reinstall only when pyproject.toml changes.
$(VENV)/.installed: pyproject.toml | $(PY)
	$(PIP) install --quiet -e .
	touch $@

$(VENV)/.installed-test: pyproject.toml | $(PY)
	$(PIP) install --quiet -e ".[test]"
	touch $@ $(VENV)/.installed $(VENV)/.installed-docs

$(VENV)/.installed-docs: pyproject.toml | $(PY)
	$(PIP) install --quiet -e ".[docs]"
	touch $@ $(VENV)/.installed

$(VENV)/.installed-bench: pyproject.toml | $(PY)
	$(PIP) install --quiet -e ".[test,bench]"
	touch $@ $(VENV)/.installed-test $(VENV)/.installed-docs $(VENV)/.installed

install: $(VENV)/.installed
install-test: $(VENV)/.installed-test

# Headless Chromium for the browser test (Debian package; needs root or sudo).
browser:
	@command -v chromium >/dev/null 2>&1 || command -v chromium-browser >/dev/null 2>&1 || { \
	  SUDO=$$( [ "$$(id -u)" = 0 ] || echo sudo ); \
	  echo "installing Debian's chromium for the browser test"; \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq chromium fonts-dejavu-core >/dev/null \
	  || echo "WARNING: could not install chromium; the browser test will be skipped"; }

demo: $(VENV)/.installed
	$(VENV)/bin/kinserve demo all --out $(DEMO_OUT)

# Style contract ([tool.ruff] in pyproject.toml): any violation fails `make test` before the suite runs.
lint: $(VENV)/.installed-test
	$(PY) -m ruff check .

# The user guide and API reference (mkdocs.yml, docs/) into site/. `python -m mkdocs`, not the `mkdocs`
# script: the script's folder (.venv/bin) holds the `kinserve` console script, which the API reference's
# loader (griffe) would take for the package. --strict: a broken link or reference, or a page missing from
# the navigation, fails the build.
MKDOCS := NO_MKDOCS_2_WARNING=1 $(PY) -m mkdocs build --strict
DOCS_OUT ?= site

docs: $(VENV)/.installed-docs
	$(MKDOCS) -d $(DOCS_OUT)

# The suite also runs every Python snippet of README.md and docs/ (tests/test_docs_snippets.py).
# The kernels are compiled once (or loaded from Numba's cache) before the suite, so its two workers load them
# and do not both compile them at the same time.
test: $(VENV)/.installed-test browser lint
	$(MKDOCS) --quiet -d $(DOCS_OUT)
	$(PY) -c "from kinserve.kinematics.kernel_cache import compile_all; compile_all()"
	$(PY) -m pytest -q -n 2 --dist loadfile

# README gallery: one plot per scenario + browser screenshots of two scenes (needs chromium).
gallery: $(VENV)/.installed browser
	$(PY) -m kinserve.scenarios.gallery --demo $(DEMO_OUT)

# Peers that pin another Pinocchio get their own venv under bench-out/venvs/<peer>, never the main .venv.
# Stamp files make it idempotent; a failed install leaves no stamp (retried next time) and the benchmarks
# skip that peer with a message.
PEER_VENVS   := bench-out/venvs
PLACO_SPEC    ?= placo==0.10.2
ROBOPLAN_SPEC ?= roboplan==0.7.0
# OMPL's validity checker is kinserve's own collision check, so its venv holds kinserve (editable) too
OMPL_SPEC     ?= -e $(CURDIR) ompl==2.0.1

$(PEER_VENVS)/%/.installed:
	@mkdir -p $(PEER_VENVS)
	@echo "peer venv $(PEER_VENVS)/$*: $($(shell echo $* | tr a-z A-Z)_SPEC)"
	@( $(PYTHON) -m venv $(PEER_VENVS)/$* \
	   && $(PEER_VENVS)/$*/bin/python -m pip install --quiet --upgrade pip \
	   && $(PEER_VENVS)/$*/bin/python -m pip install --quiet $($(shell echo $* | tr a-z A-Z)_SPEC) \
	   && touch $@ ) || echo "WARNING: could not install $* in $(PEER_VENVS)/$*; its benchmark rows will be skipped"

peers: $(PEER_VENVS)/placo/.installed $(PEER_VENVS)/roboplan/.installed $(PEER_VENVS)/ompl/.installed

# BENCH_N=50 runs the IK benchmarks on 50 targets (a quick check; the README figures use the defaults).
BENCH_N ?=
BENCH_IK_N := $(if $(BENCH_N),--n $(BENCH_N))
# MotionBenchMaker's Panda problems (VAMP's resources/panda/): the archive is unpacked into bench-out/
MBM_DATASET ?= $(CURDIR)/../shared/datasets/motion-bench-maker

bench: $(VENV)/.installed-bench peers
	mkdir -p bench-out
	$(PY) benchmarks/bench_kinematics.py --out bench-out/kinematics.json
	$(PY) benchmarks/bench_ik.py $(BENCH_IK_N) --out bench-out/ik.json
	$(PY) benchmarks/bench_ik_constrained.py $(BENCH_IK_N) --out bench-out/ik_constrained.json
	$(PY) benchmarks/bench_collision.py $(BENCH_IK_N) --out bench-out/collision.json
	$(PY) benchmarks/bench_planners.py --out bench-out/planners.json
	$(PY) benchmarks/bench_service.py --out bench-out/service.json
	$(PY) benchmarks/bench_motion.py --dataset $(MBM_DATASET) $(BENCH_IK_N) --out bench-out/motion.json
	$(PY) benchmarks/bench_clutter.py --dataset $(MBM_DATASET) $(if $(BENCH_N),--per-set $(BENCH_N),--all) --out bench-out/clutter.json
	$(PY) benchmarks/render_tables.py bench-out --out bench-out/tables.md --docs docs/benchmarks.md

clean:
	rm -rf $(VENV) $(DEMO_OUT) bench-out .pytest_cache $(DOCS_OUT)
