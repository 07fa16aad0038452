#!/usr/bin/env python3
"""Times pyfuzzylite on the thesis's avoider rule base, on the same 64 input vectors as the
Rust criterion bench (actors/avoider/benches/inference.rs), for the closing comparison.

    .venv/bin/python scripts/fuzzy_bench.py [RULES.fll]

Prints microseconds per inference one row at a time (what the avoider does per depth frame)
and, for reference, per row when pyfuzzylite evaluates all 64 rows as one numpy batch.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import fuzzylite as fl
import numpy as np

PHI = 0.6180339887498949
VECTORS = 64


def inputs() -> np.ndarray:
    """Input `j` of vector `k` is frac((10k + j + 1) * phi), as in the Rust bench."""
    return np.array(
        [[math.modf((10 * k + j + 1) * PHI)[0] for j in range(10)] for k in range(VECTORS)]
    )


def best_of(repeats: int, run) -> float:
    best = math.inf
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        best = min(best, time.perf_counter() - start)
    return best


def main() -> int:
    rules = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).parent.parent / "config/avoider/thesis.fll"
    engine = fl.FllImporter().from_file(rules)
    data = inputs()
    variables = engine.input_variables
    if len(variables) != data.shape[1]:
        raise SystemExit(f"expected {data.shape[1]} inputs, the rule base has {len(variables)}")

    def one_at_a_time() -> None:
        for row in data:
            for variable, value in zip(variables, row):
                variable.value = value
            engine.process()

    def batch() -> None:
        for i, variable in enumerate(variables):
            variable.value = data[:, i]
        engine.process()

    one_at_a_time()
    single = best_of(5, one_at_a_time) / VECTORS
    batched = best_of(20, batch) / VECTORS
    print(f"pyfuzzylite {fl.__version__}, {rules.name}, {VECTORS} input vectors")
    print(f"one inference at a time: {single * 1e6:.1f} us per inference")
    print(f"numpy batch of {VECTORS}:     {batched * 1e6:.1f} us per inference")
    return 0


if __name__ == "__main__":
    sys.exit(main())
