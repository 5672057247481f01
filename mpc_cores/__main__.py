"""`python -m mpc_cores <command>`: the same as the `mpc-cores` console command."""
from mpc_cores.cli import main

main()
