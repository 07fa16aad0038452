#!/usr/bin/env python3
"""Independent reference for Kestrel's fuzzy engine: evaluate a fuzzylite rule base (.fll)
with pyfuzzylite on every row of a CSV of inputs and write the outputs as CSV.

    .venv/bin/python scripts/fuzzy_reference.py RULES.fll INPUTS.csv OUTPUTS.csv

INPUTS.csv has a header naming input variables (any order, every input once) and one row per
evaluation. OUTPUTS.csv gets a header of the engine's output variables and one row per input
row, values written with 17 significant digits ("nan" where fuzzylite gives no value).
The actors/avoider agreement tests run this through <repo>/.venv (scripts/python-env.sh).
"""

from __future__ import annotations

import csv
import sys

import fuzzylite as fl
import numpy as np


def evaluate(engine: fl.Engine, columns: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Evaluates all rows at once (pyfuzzylite 8 processes numpy arrays elementwise)."""
    names = [v.name for v in engine.input_variables]
    missing = sorted(set(names) - set(columns))
    unknown = sorted(set(columns) - set(names))
    if missing or unknown:
        raise SystemExit(f"fuzzy_reference: missing inputs {missing}, unknown inputs {unknown}")
    for variable in engine.input_variables:
        variable.value = columns[variable.name]
    engine.process()
    rows = len(next(iter(columns.values())))
    return {
        v.name: np.broadcast_to(np.atleast_1d(v.value).astype(float), (rows,))
        for v in engine.output_variables
    }


def main(argv: list[str]) -> int:
    if len(argv) != 4:
        print(__doc__, file=sys.stderr)
        return 2
    rules, inputs_csv, outputs_csv = argv[1:]
    engine = fl.FllImporter().from_file(rules)
    with open(inputs_csv, newline="") as f:
        reader = csv.reader(f)
        header = next(reader)
        rows = [[float(x) for x in row] for row in reader if row]
    data = np.array(rows, dtype=float).reshape(len(rows), len(header))
    outputs = evaluate(engine, {name: data[:, i] for i, name in enumerate(header)})
    with open(outputs_csv, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(outputs.keys())
        for values in zip(*outputs.values()):
            writer.writerow(f"{v:.17g}" for v in values)
    return 0


if __name__ == "__main__":
    with np.errstate(all="ignore"):
        sys.exit(main(sys.argv))
