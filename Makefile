# manipkit: `make demo` installs manipkit and prints the course arm's base -> ee transform (nothing compiled);
# `make test` sets up the test tools and runs the whole test suite; `make docs` builds the site into site/.
# The numba kernels compile on their first use, one line on stderr saying which and about how long, and are
# kept in ~/.cache/manipkit/kernels (or NUMBA_CACHE_DIR) for later runs; `make kernels` compiles them all ahead.

PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV   := .venv
BIN    := $(VENV)/bin
BASE   := $(VENV)/.installed-base
STAMP  := $(VENV)/.installed
DOCS   := $(VENV)/.installed-docs

CHROMIUM := /usr/bin/chromium
DOT      := /usr/bin/dot

.PHONY: setup demo test lint browser notebooks clean docs kernels

setup: $(STAMP)

# manipkit itself, as `pip install manipkit` would install it: what `make demo` needs, nothing compiled. Not even
# bytecode: pip's compiling every module of the ~60 packages took about 45 s of a 114 s `make demo`, and Python
# writes the bytecode of what a command imports when it first imports it (as `make test` and `make bench` let it).
$(BASE): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --no-compile -e .
	touch $(BASE)

# and the test tools (the dev extra)
$(STAMP): $(BASE)
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

demo: $(BASE)
	$(BIN)/tf-between base_link ee_link --robot course_arm

# Every kernel compiled ahead (a few minutes on 2 cores; each 6R family's closed form about a minute of it), for
# a machine image or CI; never needed: each kernel compiles on its first use otherwise.
kernels: $(BASE)
	$(BIN)/python -c "from manipkit.ik.lm_kernel import warm_up; warm_up()"
	$(BIN)/python -c "from manipkit.closed_form.arms_kernel import warm_up; warm_up()"
	$(BIN)/python -c "from manipkit.closed_form.general6r import warm_up; warm_up()"
	$(BIN)/python -c "from manipkit.ik.aliases import warm_up; warm_up()"
	$(BIN)/python -c "from manipkit.closed_form.spherical12_kernel import warm_up; warm_up()"
	$(BIN)/python -c "import manipkit; r = manipkit.load('panda'); c = r.chain('base_link', 'ee_link'); \
		manipkit.ik(r, c.fk(c.sample(1)[0]), all=True)"  # a 7R ranked set's compiled sweep (ik.redundant_kernel)

# The viewer tests drive Debian's Chromium (headless); the tree tests render DOT with Graphviz.
# Both are installed when missing.
browser: $(CHROMIUM) $(DOT)

$(CHROMIUM):
	@if [ "$$(id -u)" = 0 ]; then sudo=; else sudo=sudo; fi; \
	$$sudo apt-get update -qq && $$sudo apt-get install -y -qq chromium chromium-driver

$(DOT):
	@if [ "$$(id -u)" = 0 ]; then sudo=; else sudo=sudo; fi; \
	$$sudo apt-get update -qq && $$sudo apt-get install -y -qq graphviz

# One worker process per core (pytest-xdist), each taking whole test files, so a module's fixtures run once.
# Bytecode is written (__pycache__/, git-ignored) even where the environment sets PYTHONDONTWRITEBYTECODE: else
# each worker rewrites and compiles every test module again (19 s -> 8 s of CPU to collect the suite, each
# worker), and every command a test runs as a process compiles manipkit's modules again.
test: setup browser lint
	PYTHONDONTWRITEBYTECODE= $(BIN)/python -m pytest -n auto --dist loadfile

# Style and import checks (ruff, configured in pyproject.toml); part of `make test`.
lint: setup
	$(BIN)/ruff check src tests benchmarks

notebooks: setup
	$(BIN)/python -m pip install --quiet -e '.[notebooks]'
	$(BIN)/jupyter lab notebooks/

clean:
	rm -rf $(VENV) .pytest_cache build dist site

# The documentation site (MkDocs, mkdocstrings' numpy docstrings, the command-line reference generated from
# the parsers) into site/; --strict: any warning fails the build.
$(DOCS): $(BASE)
	$(BIN)/python -m pip install --quiet -e '.[docs]'
	touch $(DOCS)

docs: $(DOCS)
	$(BIN)/mkdocs build --strict

# Side-by-side speed comparisons with Robotics Toolbox, ikpy, kinpy and Pinocchio (minutes):
# installs the bench extra, prints the table, writes benchmarks/results.json and results.png and
# updates the table in benchmarks/README.md.
.PHONY: bench
bench: setup
	$(BIN)/python -m pip install --quiet -e '.[bench]'
	PYTHONDONTWRITEBYTECODE= $(BIN)/python -m benchmarks  # the cold starts timed with bytecode, as users have it

# The task-path planners of roboplan and Tesseract (Descartes) beside plan_path on the same UR5 lines
# (benchmarks/bench_path_peers.py, about two minutes). Each peer gets its own venv under .peers/, since roboplan
# brings its own Pinocchio/coal/eigenpy wheels: never installed into .venv, never part of `make test`.
.PHONY: peers
peers: setup
	test -x .peers/roboplan/bin/python || $(PYTHON) -m venv .peers/roboplan
	.peers/roboplan/bin/python -m pip install --quiet roboplan==0.7.0
	test -x .peers/tesseract/bin/python || $(PYTHON) -m venv .peers/tesseract
	.peers/tesseract/bin/python -m pip install --quiet tesseract-robotics==0.5.1
	$(BIN)/python -m benchmarks.bench_path_peers

# Fuzz the description loaders with 10,000 mutated URDF and 10,000 mutated xacro cases, and the
# xacro expression evaluator with 10,000 random expression trees of allowed and forbidden nodes
# twice (tests/test_fuzz.py; `make test` runs 300 of each): about 15 minutes. A failing case's shrunk
# input is written to /tmp/manipkit_fuzz_failure.urdf (or /tmp/manipkit_fuzz_failure_xacro/). Then 1,000 cases
# each of collision mesh vertices, world files and namespaced URDF (tests/test_fuzz_hostile.py, issue 40).
.PHONY: fuzz
fuzz: setup
	HYPOTHESIS_PROFILE=explore MANIPKIT_FUZZ_EXAMPLES=10000 $(BIN)/python -m pytest tests/test_fuzz.py -q --hypothesis-show-statistics -k "mutated or xacro_expression"
	MANIPKIT_FUZZ_EXAMPLES=1000 $(BIN)/python -m pytest tests/test_fuzz_hostile.py -q --hypothesis-show-statistics
