"""The testplan as data: per core kind (and for the shared blocks), each feature and the tests that cover it, as
pytest node ids `tests/<file>.py::<function>` (a `[<param>]` names the kind's case of a test run for every kind).
tests/test_testplan.py checks that every test named here exists, that every test of the RTL suites is named here,
and that docs/verification.md holds this plan as `render()` writes it."""
from __future__ import annotations

KINDS = ("fgm", "admm", "ama", "vucondat", "dgp", "minres", "ipm")

# features every kind goes through, and the suite test (parametrized by kind) that covers each
SUITES = {
    "AXI4-Lite fuzz during solves, AXI4-Stream tlast errors and gaps, reset sweep": "tests/test_fuzz.py::test_protocol_fuzz",
    "the same fuzz, long (slow marker)": "tests/test_fuzz.py::test_protocol_fuzz_long",
    "register readback against the RDL over AXI4-Lite": "tests/test_regmap.py::test_readback_over_axi",
    "the RDL, core.json, the C header's offsets, the IP-XACT memory map and the register reference agree":
        "tests/test_regmap.py::test_rdl_agrees_with_core_json",
    "the generated register files are named in core.json": "tests/test_regmap.py::test_outputs_named_in_core_json",
    "data regions at the documented addresses": "tests/test_regmap.py::test_region_addresses_follow_the_documented_layout",
    "the PeakRDL C header compiles with the offsets": "tests/test_regmap.py::test_c_header_compiles_with_the_offsets",
    "the IP-XACT memory map names the registers": "tests/test_regmap.py::test_ipxact_names_the_registers",
    "the register reference (markdown)": "tests/test_regmap.py::test_regmap_doc",
    "the docs page follows the core template, its register table generated from the map":
        "tests/test_regmap.py::test_docs_page_follows_the_template_with_the_generated_registers",
    "protocol assertions in the simulation": "tests/test_assertions.py::test_assertions_outside_synthesis",
    "a forced protocol violation stops the simulation": "tests/test_assertions.py::test_violation_stops_the_simulation",
    "IP-XACT component against the IEEE 1685-2022 schema": "tests/test_ipxact.py::test_component_validates_against_the_schema",
    "FuseSoC lint target with the venv's tools": "tests/test_packaging.py::test_fusesoc_lint",
    "soak space: random configurations the flow accepts": "tests/test_soak.py::test_random_space_mostly_accepted",
}

_ADMM_RTL = ["tests/test_admm_rtl.py::test_rtl_matches_golden_model", "tests/test_admm_acc_rtl.py::test_accelerated_rtl_matches_golden_model"]

# features of one kind: the tests that cover them (the kind's own suites)
OWN = {
    "fgm": {
        "RTL word for word against the golden model (random solves, warm and cold, IMAX, idle, backpressure, resets, "
        "interleaved problems, the exit test)": ["tests/test_fgm_rtl.py::test_rtl_matches_golden_model"],
        "cycle contract in core.json, measured in Verilator": ["tests/test_fgm_rtl.py::test_rtl_matches_golden_model"],
        "the generator refuses invalid configurations": ["tests/test_fgm_rtl.py::test_generator_refuses_invalid_configs"],
        "closed loop with the RTL equals the golden model's": ["tests/test_closed_loop.py::test_rtl_in_the_loop_equals_golden"],
        "certified bounds hold on the RTL": ["tests/test_guarantees.py::test_certified_core_meets_its_bounds_on_rtl"],
        "C twin word for word": ["tests/test_c.py::test_bit_exact"],
        "C driver on the RTL": ["tests/test_driver.py::test_driver_on_the_rtl", "tests/test_driver.py::test_driver_with_the_exit_test"],
    },
    "admm": {
        "RTL word for word against the golden model (soft pairs, rate, lanes, accelerated, interleaved)": _ADMM_RTL,
        "the plain form (no input_rate)": ["tests/test_admm_rtl.py::test_rtl_norate_layout"],
        "cycle contract in core.json, measured in Verilator": ["tests/test_admm_rtl.py::test_contract_in_core_json"],
        "the generator refuses invalid configurations": ["tests/test_admm_rtl.py::test_generator_refuses_invalid_configs"],
        "closed loop with the RTL equals the golden model's": ["tests/test_admm_rtl.py::test_rtl_norate_closed_loop"],
        "heterogeneous split: the linear-system block in RTL": ["tests/test_split.py::test_linstep_rtl",
                                                              "tests/test_split.py::test_split_closed_loop_equals_all_hardware"],
        "C twin word for word": ["tests/test_c.py::test_bit_exact"],
        "C driver on the RTL": ["tests/test_driver.py::test_driver_on_the_rtl"],
    },
    "ama": {"RTL word for word against the golden model (the ADMM datapath's cases of the method)": _ADMM_RTL,
            "C driver on the RTL": ["tests/test_driver.py::test_driver_on_the_rtl"]},
    "vucondat": {"RTL word for word against the golden model (the ADMM datapath's cases of the method)": _ADMM_RTL,
                 "C driver on the RTL": ["tests/test_driver.py::test_driver_on_the_rtl"]},
    "dgp": {
        "RTL word for word against the golden model, status word, ITERATIONS and the cycle contract (both forms)":
            ["tests/test_dgp_rtl.py::test_rtl_bitexact"],
        "P row units (P = 2, 3 with padded rows; masses_state P = 4 on the ECP5 with kept copies)":
            ["tests/test_dgp_rtl.py::test_rtl_bitexact"],
        "core.json and the report name (36), (37) and the cycle contract": ["tests/test_dgp_rtl.py::test_masses_state_report"],
        "zero start (the first passes K and G skipped) and a warm start from a nonzero dual, cycles and ITERATIONS.ZERO_START":
            ["tests/test_dgp_rtl.py::test_rtl_bitexact", "tests/test_dgp_model.py::test_warm_start_state"],
        "C twin word for word": ["tests/test_dgp_c.py::test_bit_exact"],
        "C driver on the RTL": ["tests/test_driver.py::test_driver_on_the_rtl"],
    },
    "minres": {
        "RTL word for word against the golden model, non-finite flagged": ["tests/test_minres_rtl.py::test_rtl_matches_golden_model",
                                                                          "tests/test_minres_rtl.py::test_masses_rtl"],
        "cycles per iteration and core.json": ["tests/test_minres_rtl.py::test_masses_core_json",
                                               "tests/test_minres_rtl.py::test_format_in_core_json"],
        "the generator refuses invalid configurations": ["tests/test_minres_rtl.py::test_generator_refusals"],
    },
    "ipm": {
        "RTL word for word against the golden model, problems in flight, latency, infeasible and non-finite answers":
            ["tests/test_ipm_rtl.py::test_rtl_matches_golden_model"],
        "core.json's cycle contract": ["tests/test_ipm_rtl.py::test_masses_core_json"],
        "Stage 1 engine against its interpreter": ["tests/test_ipm_stage1_rtl.py::test_engine_matches_interpreter",
                                                   "tests/test_ipm_stage1_rtl.py::test_stream_hazards",
                                                   "tests/test_ipm_stage1_rtl.py::test_encoding_roundtrip",
                                                   "tests/test_ipm_stage1_rtl.py::test_generator_refusals"],
        "closed loop with the RTL (make demo) equals the golden model's": ["tests/test_ipm_demo.py::test_ipm_demo_rtl_equals_golden"],
    },
}

SHARED = {
    "shared blocks against models of their contracts (RegSlice, FlowQueue, AnswerQueue, FrameIn, PassSequencer, "
    "TurnSequencer, SerialDivider, InitRam)": ["tests/test_blocks.py::test_block"],
    "the shared blocks' assertions fire on a forced violation": ["tests/test_blocks.py::test_violation_stops_the_simulation"],
    "float operators against the bit-exact model": ["tests/test_float_rtl.py::test_rtl_matches_model",
                                                    "tests/test_float_rtl.py::test_latency_parameter",
                                                    "tests/test_float_rtl.py::test_fully_pipelined",
                                                    "tests/test_float_rtl.py::test_mul_on_ecp5_dsp",
                                                    "tests/test_float_rtl.py::test_mul_corners_reach_every_case",
                                                    "tests/test_float_rtl.py::test_generator_refusals"],
    "ECP5 block RAMs (DP16KD primitives) read and write as the behavioural model": [
        "tests/test_ecp5_bram.py::test_synthesis_branch_reads_and_writes", "tests/test_ecp5_bram.py::test_sdp_synthesis_branch"],
    "the float kinds write no C driver": ["tests/test_driver.py::test_kinds_without_a_driver_write_none"],
    "the models compile through ccache: Verilator's runtime once per set of flags":
        ["tests/test_ccache.py::test_runtime_compiled_once_across_models"],
    "every kind runs every per-kind suite": ["tests/test_suites.py::test_every_kind_runs_or_has_a_reason",
                                             "tests/test_suites.py::test_collected_suites_run_every_kind"],
}

# the files whose every test must be in the plan
RTL_FILES = ("test_fgm_rtl.py", "test_admm_rtl.py", "test_admm_acc_rtl.py", "test_dgp_rtl.py", "test_minres_rtl.py",
             "test_ipm_rtl.py", "test_ipm_stage1_rtl.py", "test_float_rtl.py", "test_blocks.py", "test_fuzz.py",
             "test_regmap.py", "test_assertions.py", "test_driver.py", "test_ecp5_bram.py")


def entries() -> list[tuple[str, str, str]]:
    """(kind or "shared", feature, node id) of every line of the plan"""
    out = [(k, f, f"{t}[{k}]") for k in KINDS for f, t in SUITES.items()]
    out += [(k, f, t) for k, feats in OWN.items() for f, ts in feats.items() for t in ts]
    out += [("shared", f, t) for f, ts in SHARED.items() for t in ts]
    return out


def render() -> str:
    """The plan in markdown: the per-kind suites (each run for every kind), then each kind's own features and the
    shared blocks'"""
    def refs(ts):
        return ", ".join(f"`{t.split('/')[-1]}`" for t in ts)
    lines = [f"**Every kind** ({', '.join(KINDS)}), each suite parametrized by the kind:", ""]
    lines += [f"- {f}: `{t.split('/')[-1]}[kind]`" for f, t in SUITES.items()]
    for k in KINDS:
        lines += ["", f"**{k}**", ""]
        lines += [f"- {f}: {refs(ts)}" for f, ts in OWN.get(k, {}).items()]
    lines += ["", "**Shared blocks**", ""]
    lines += [f"- {f}: {refs(ts)}" for f, ts in SHARED.items()]
    return "\n".join(lines) + "\n"
