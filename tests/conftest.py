import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def pytest_addoption(parser):
    parser.addoption("--random-solves", type=int, default=None,
                     help="random solves per core in the bit-exact RTL test (default: per case)")
