# User interface of the project: setup, verilog, c, design, test, demo, clean.
PYTHON      ?= python3
VENV        ?= .venv
PY          := $(VENV)/bin/python
MPC         := $(VENV)/bin/mpc-cores
SBT_VERSION := 1.11.7
SBT_JAR     := $(HOME)/.m2/repository/org/scala-sbt/sbt-launch/$(SBT_VERSION)/sbt-launch-$(SBT_VERSION).jar

.DEFAULT_GOAL := help

##v CORE: core kind (kinds: fgm, admm, ama, vucondat, minres, ipm, dgp), default fgm
##v PROBLEM: the MPC spec (default examples/masses.yaml; the format: docs/spec.md)
##v P, B: row units, fraction bits (override the spec's solver: section, as the variables below)
##v OUT: output folder
##v TOL: make design: a tolerance the design is certified for (kinds: fgm, dgp)
##v TARGET, LAT_ADD, LAT_MUL: FPGA family of the multipliers (generic, ecp5, xilinx7), pipeline registers
##v PROBLEMS: K_p problems interleaved on the row units (kinds: fgm, admm, ama, vucondat)
##v LANES: multipliers per row unit, or fit (sized for the LFE5U-85F) (kinds: admm, ama, vucondat, dgp)
##v EARLY_EXIT: fgm: true builds the exit test (a solve ends once z stops moving, else at IMAX)
##v EXIT_TOL: fgm: the exit test's tolerance in the units of u (builds the test; default 2 LSB)
##v FORMAT, LATENCY: float cores (kinds: minres, ipm): format (binary32, e8m17, ...) and operator latencies (compact, fast)
##v MULTIPLEXED: ipm: 1 builds parallel multiplexed MPC (one input's problem per channel; Algorithm 2 of 001)
##v ITER: iteration count (Imax; I_MR for ipm); without it the spec's, or the design check's choice for GAP
##v GAP, CYCLES, CHECK: design check: target closed-loop cost gap in percent, cycle budget per solve; CHECK=0 skips it
##v JOBS, PYTEST_ARGS, WAVES: make test: workers (default auto), more pytest arguments, WAVES=1 traces every simulation
##v SOLVES, SEED, CONFIG_SEED: make soak: solves (default 10^4; N is the old name), seeds
##v QUICK, BENCH, BENCH_ARGS: make bench: the short sweep, the output folder, more arguments
CORE    ?= fgm
PROBLEM ?= examples/masses.yaml
P       ?=
B       ?=
OUT     ?=
TOL     ?=
# FPGA family of the multipliers (fgm, admm): generic, ecp5 or xilinx7; pipeline latencies l_A, l_M
TARGET  ?=
LAT_ADD ?=
LAT_MUL ?=
# FGM: problems interleaved on the row units (K_p)
PROBLEMS ?=
# ADMM family: multipliers per row unit (a row in chunks), or fit (the fewest chunks that fit the LFE5U-85F)
LANES   ?=
# FGM: the exit test (EARLY_EXIT=true) and its tolerance in the units of u
EARLY_EXIT ?=
EXIT_TOL   ?=
# float cores (minres, ipm): format (binary32, e8m17, ...) and operator latencies (compact or fast)
FORMAT  ?=
LATENCY ?=
# ipm: parallel multiplexed MPC (1)
MULTIPLEXED ?=
# iteration count (Imax; I_MR for ipm): without it, the spec's, or the design check's choice for a GAP target
ITER    ?=
# design check (mpc_cores.check): target closed-loop cost gap in percent, budget of cycles per solve; CHECK=0 skips it
GAP     ?=
CYCLES  ?=
CHECK   ?= 1
PYTEST_ARGS ?=
# parallel test workers (pytest-xdist, one per core); a test file runs on one worker (its module fixtures
# regenerate cores in place)
JOBS        ?= auto

GEN_ARGS = --core $(CORE) --problem $(PROBLEM) $(if $(P),--P $(P)) $(if $(B),--frac-bits $(B)) $(if $(OUT),--out $(OUT)) \
           $(if $(TARGET),--target $(TARGET)) $(if $(LAT_ADD),--lat-add $(LAT_ADD)) $(if $(LAT_MUL),--lat-mul $(LAT_MUL)) \
           $(if $(PROBLEMS),--problems $(PROBLEMS)) $(if $(LANES),--lanes $(LANES)) \
           $(if $(EARLY_EXIT),--early-exit $(EARLY_EXIT)) $(if $(EXIT_TOL),--exit-tol $(EXIT_TOL)) $(if $(FORMAT),--format $(FORMAT)) $(if $(LATENCY),--latency $(LATENCY)) \
           $(if $(filter 1 true,$(MULTIPLEXED)),--multiplexed true) \
           $(if $(ITER),--iterations $(ITER)) $(if $(GAP),--gap $(GAP)) $(if $(CYCLES),--cycles $(CYCLES)) $(if $(filter 0,$(CHECK)),--no-check)

.PHONY: help setup verilog c split design test test-slow demo table2 methods bench scaling soak soak-all gallery clean test-float

## help: the targets and the variables (the default goal)
help:
	@echo "Targets (make <target> [VAR=value ...]):"
	@awk '/^## [a-z0-9-]+:/ { sub(/^## /, ""); n = index($$0, ":"); printf "  %-10s %s\n", substr($$0, 1, n - 1), substr($$0, n + 2); next } \
	      /^## / { sub(/^## /, ""); printf "  %-10s %s\n", "", $$0 }' $(firstword $(MAKEFILE_LIST))
	@echo "Variables:"
	@awk '/^##v / { sub(/^##v /, ""); n = index($$0, ":"); printf "  %-26s %s\n", substr($$0, 1, n - 1), substr($$0, n + 2) }' $(firstword $(MAKEFILE_LIST))

$(VENV)/.installed: requirements.txt pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --disable-pip-version-check -r requirements.txt
	$(PY) -m pip install -q --disable-pip-version-check --no-deps -e .
	$(PY) -m mpc_cores.shims
	touch $@

$(SBT_JAR):
	mvn -q dependency:get -Dartifact=org.scala-sbt:sbt-launch:$(SBT_VERSION) -Dtransitive=false

## setup: Python environment (.venv, pinned requirements.txt) and the sbt launcher; sbt fetches Chisel on first use
setup: $(VENV)/.installed $(SBT_JAR)

## verilog: SystemVerilog, core.json and C header of CORE for PROBLEM into OUT (P, B override the spec)
verilog: setup
	$(MPC) verilog $(GEN_ARGS)

## c: portable C99 solvers of CORE (kinds: fgm, admm, ama, vucondat, dgp) for PROBLEM into OUT, bit-exact fixed point and float (the same
## overrides as verilog; needs the Python environment and gcc to build them, not sbt or Java)
c: $(VENV)/.installed
	$(MPC) c $(GEN_ARGS)

## split: the heterogeneous split of CORE (kinds: admm, ama, vucondat) into OUT: the hardware block of the linear-system
## step s = M11 v (<module>_linstep.sv, linstep.json) and the C solvers, whose _solve_split calls it
split: setup
	$(MPC) split $(GEN_ARGS)

## design: design report; with TOL, choose frac_bits and Imax with guarantees and write the spec for `make verilog`
design: setup
	$(MPC) design $(GEN_ARGS) $(if $(TOL),--tol $(TOL))

## test: the verification suite (golden models, RTL against them in Verilator, refusals); WAVES=1 traces every
## cocotb run to a waveform beside its log (<log>.fst, e.g. sim.fst; VCD without the lz4 headers), its path in the log
test: setup
	$(PY) -m pytest tests -q -n $(JOBS) --dist loadfile --durations=15 $(PYTEST_ARGS)

## test-slow: the long sweeps (cycles per iteration of masses for P = 1, 2, 4, 8, 40)
test-slow: setup
	$(PY) -m pytest tests -q -s -m slow $(PYTEST_ARGS)

## demo: generate CORE (kinds: fgm, admm, ama, vucondat, ipm, dgp) for PROBLEM and run it in a closed loop with the
## Verilator model (OUT: build/demo)
demo: setup
	$(MPC) demo $(GEN_ARGS)

## table2: closed-loop cost tables (Table II(a) of 002, Table I of 000), Fig. 5/6 and the RTL subset into
## build/reports (TABLE_ARGS, e.g. --no-rtl)
table2: setup
	$(MPC) table2 $(TABLE_ARGS)

## methods: comparison of the splitting family (ADMM, AMA, Vu-Condat; plain/accelerated, with/without the power-of-two
## preconditioner) and the DGP in float64 into build/reports/methods.md and methods.json (METHODS_ARGS, e.g. --quick)
methods: $(VENV)/.installed
	$(MPC) methods --out build/reports $(METHODS_ARGS)

## bench: benchmark report of every kind's cores into BENCH (cycles, Yosys resources, nextpnr Fmax on the LFE5U-85F,
## latency against the papers and the CPU solvers DAQP, OSQP, TinyMPC by their own timers); QUICK=1 for the short
## run (one Fmax seed, no Xilinx synthesis); BENCH_ARGS for more (e.g. --jobs 1, --cores admm, --no-xilinx)
BENCH ?= build/bench
$(VENV)/.bench-installed: requirements-bench.txt $(VENV)/.installed
	$(PY) -m pip install -q -r requirements-bench.txt
	@# TinyMPC built from its source, without its declared scipy < 1.12 (it runs on the pinned scipy); where it does
	@# not build, the bench reports it as not installed
	-$(PY) -m pip install -q --no-deps tinympc==0.0.8
	touch $@

bench: setup $(VENV)/.bench-installed
	$(MPC) bench --out $(BENCH) $(if $(QUICK),--quick) $(BENCH_ARGS)

## scaling: the FGM and DGP cores against DAQP and OSQP as the problem grows (chains of M masses, horizon N; QUICK=1 for the
## small grid; the last section of a full make bench) into BENCH: scaling.md, scaling.csv, scaling.png (the clocks: the
## FGM and DGP sections' placed Fmax in BENCH)
scaling: setup $(VENV)/.bench-installed
	$(PY) -m mpc_bench.scaling --out $(BENCH) $(if $(QUICK),--quick) --docs docs/bench

## soak: SOLVES random solves of CORE (default 10^4) over random configurations (sizes, constraint sets, P, b, latencies,
## roundings, formats), each generated and run in Verilator against its golden model word for word under random idle
## and backpressure; report docs/soak/CORE.md and CORE.json (SEED; CONFIG_SEED=<seed> SOLVES=<solves> reruns one)
N           ?= 10000
SOLVES      ?= $(N)
SEED        ?= 1
CONFIG_SEED ?=
soak: setup
	$(MPC) soak --core $(CORE) --solves $(SOLVES) --seed $(SEED) $(if $(CONFIG_SEED),--config-seed $(CONFIG_SEED))

## soak-all: `make soak` for every kind of the registry with a soak space, one after another, SOLVES each (default
## 10^4; SEED), a progress bar over the kinds and one line per kind as it ends; reports in docs/soak/
soak-all: setup
	$(MPC) soak --all --solves $(SOLVES) --seed $(SEED)

## gallery: every kind on every plant of examples/ through its design flow and check, into docs/gallery.md
## (GALLERY_ARGS, e.g. --plants quadrotor,cartpole --kinds fgm,admm)
gallery: $(VENV)/.installed
	$(MPC) gallery $(GALLERY_ARGS)

## clean: remove build folders only
clean:
	rm -rf build target project/target project/project

## test-float: the floating-point library alone (model against numpy, RTL against the model; about 1.5 minutes)
test-float: setup
	$(PY) -m pytest tests/test_float_model.py tests/test_float_rtl.py -q $(PYTEST_ARGS)
