"""The protocol fuzz's family of the ADMM core and its method kinds (verif/fuzz/kinds.py): the shared fixed-point
adapter."""
from verif.fuzz.kinds import Family, FixedKind

FAMILY = Family(FixedKind, "mpc_cores.driver:TB")
