# Two commands do all the set-up on a fresh machine (see README.md):
#   make demo   generate, compile and simulate the paper's double pendulum
#   make test   run the test suite
VENV ?= .venv
STAMP := $(VENV)/.impactgen-installed

.PHONY: setup demo test check-sundials7 clean

setup: $(STAMP)

$(STAMP): pyproject.toml scripts/setup.sh
	VENV=$(VENV) ./scripts/setup.sh
	touch $@

demo: $(STAMP)
	$(VENV)/bin/impactgen run scenes/paper.toml
	$(VENV)/bin/impactgen paper-table

# the tests on every core (pytest-xdist), a test file's tests in one worker so that the file's
# fixtures (FMUs, cross-checks) are built once, the files in the collection's order (the tests
# marked first lead it: see tests/conftest.py); make test WORKERS=0 runs them in one process
WORKERS ?= auto
test: $(STAMP)
	$(VENV)/bin/python -m pytest -q -n $(WORKERS) --dist loadscope --no-loadscope-reorder

# SUNDIALS 7 from Debian unstable, unpacked in a temporary folder (docs/safety.md)
check-sundials7: $(STAMP)
	PYTHON=$(VENV)/bin/python ./scripts/check_sundials7.sh

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache
