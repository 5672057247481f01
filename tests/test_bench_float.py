"""The floating-point operators' part of the benchmark (mpc_bench/float_ops.py) on canned data: no sbt, no Yosys,
no nextpnr."""
from __future__ import annotations

from pathlib import Path

from mpc_bench import float_ops


def test_plan_covers_every_operator_format_and_latency():
    full = float_ops.plan(Path("build/x"), quick=False)
    assert {(c.op, c.expW, c.manW, c.latency, c.target) for c in full} == {
        (op, e, m, lat, "generic") for op in ("add", "mul", "div", "sqrt") for e, m in ((8, 17), (8, 23))
        for lat in ("default", "steps")} | {("mul", 8, 17, lat, "ecp5") for lat in ("default", "steps")}
    assert all(c.seeds == (1, 2, 3) for c in full)
    assert all(c.seeds == (1,) for c in float_ops.plan(Path("build/x"), quick=True))
    assert len({c.out for c in full}) == len(full)


def test_wrapper_registers_every_port():
    info = {"width": 26, "out_width": 26, "module": "FloatTop_add_e8_m17_l10"}
    sv = float_ops.wrapper_sv(info)
    assert "FloatTop_add_e8_m17_l10 u(" in sv
    assert "input [25:0] ia" in sv and "output reg [25:0] oo" in sv
    assert "v <= iv; op <= iop; a <= ia; b <= ib; ov <= ovw; oo <= oow; of <= ofw;" in sv


def test_table_gives_median_seeds_and_failures():
    ok = float_ops.OpCore("mul", 8, 23, "steps", Path("a"), info={"latency": 13})
    ok.ecp5 = {"LUT4": 411, "CCU2C": 87, "FF": 939, "MULT18X18D": 4}
    ok.pnr = {"fmax_mhz": 176.8, "fmax_seeds": [170.1, 176.8, 180.2],
              "critical_path": {"signals": ["r1_x", "prod_rp_hh"], "from": "f", "to": "t"}}
    bad = float_ops.OpCore("div", 8, 17, "default", Path("b"), info={"latency": 13}, error="nextpnr failed (exit 1)")
    md = "\n".join(float_ops.section_md([ok, bad]))
    assert ("| mul | binary32 | generic | 13 (steps) | 411 | 87 | 939 | 4 | 176.8 | 170.1, 176.8, 180.2 | "
            "r1_x -> prod_rp_hh |") in md
    assert "| div | e8m17 | generic | 13 (default) | | | | | - | | nextpnr failed (exit 1) |" in md
    assert "seeds 1, 2, 3 (median)" in md
    assert float_ops.section_md([]) == []


def _operator(folder: Path) -> float_ops.OpCore:
    folder.mkdir(parents=True)
    (folder / "op.sv").write_text("module FloatTop_add(input clock); endmodule\n")
    (folder / "fmax_top.v").write_text("module fmax_top(input clock); endmodule\n")
    (folder / "clock.lpf").write_text('FREQUENCY PORT "clock" 250 MHZ;\n')
    return float_ops.OpCore("add", 8, 17, "default", folder, seeds=(1, 2), info={"sv": "op.sv", "latency": 10})


def test_placements_recorded_then_taken_from_the_store(tmp_path, monkeypatch):
    """A run records its synthesis and every seed's placement in the result store; an operator of the same Verilog
    in a fresh folder (a fresh clone) takes them from there with no tool run; a changed Verilog runs the tools."""
    from mpc_bench import store

    fmax = {"1": 240.5, "2": 251.25}
    ran = []

    def fake_run(args, cwd, **_):
        ran.append(args[0])
        if "yosys" in args[0]:
            (Path(cwd) / "stat.txt").write_text("=== fmax_top ===\n\n        2 cells\n        5   LUT4\n"
                                                "        7   TRELLIS_FF\n")
        else:
            seed = args[args.index("--seed") + 1]
            (Path(cwd) / args[args.index("--report") + 1]).write_text(
                f'{{"fmax": {{"clk": {{"achieved": {fmax[seed]}, "constraint": 250.0}}}}}}')
        return float_ops.subprocess.CompletedProcess(args, 0, "")

    monkeypatch.setattr(float_ops.subprocess, "run", fake_run)
    monkeypatch.setattr(float_ops, "_tool", lambda name: name)     # make test's venv has no nextpnr
    st = store.use(tmp_path / "results.jsonl")
    try:
        a = _operator(tmp_path / "a")
        float_ops.place(a, lambda m: None)
        assert not a.error and len(ran) == 3 and st.recorded == 3
        assert a.pnr["fmax_seeds"] == [240.5, 251.25] and a.ecp5["LUT4"] == 5 and a.ecp5["FF"] == 7

        fresh = store.use(tmp_path / "results.jsonl")     # a new process reads the file
        b = _operator(tmp_path / "b")
        float_ops.place(b, lambda m: None)
        assert len(ran) == 3 and fresh.reused == 3
        assert b.pnr == a.pnr and b.ecp5 == a.ecp5

        c = _operator(tmp_path / "c")
        (c.out / "op.sv").write_text("module FloatTop_add(input clock, input x); endmodule\n")
        float_ops.place(c, lambda m: None)
        assert len(ran) == 6
    finally:
        store.use(None)
