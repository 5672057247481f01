"""The protocol fuzz's family of the FGM core (verif/fuzz/kinds.py): the shared fixed-point adapter, and the
output-stream violations forced into its answer queue."""
from verif.fuzz.kinds import Family, FixedKind

FAMILY = Family(FixedKind, "mpc_cores.driver:TB", ("stream_valid_dropped", "stream_data_changed"))
