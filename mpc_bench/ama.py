"""AMA section of the benchmark: mpc_bench.splitting on the method `ama` of the ADMM core."""
from mpc_bench.splitting import SplittingSection


class Section(SplittingSection):
    name, label, method = "ama", "AMA", "ama"
