"""Independent reference for the compass calibration's ellipsoid fit (numpy only).

Usage: ellipsoid_reference.py SAMPLES.csv EXPECTED_FIELD_GAUSS
Reads x,y,z readings (gauss, one header line), fits the general quadric
  a x² + b y² + c z² + 2d xy + 2e xz + 2f yz + 2g x + 2h y + 2i z + j = 0
as the right singular vector of the smallest singular value of the design matrix (total least
squares, unlike the Rust fit's ordinary least squares plus geometric refinement), and prints
the hard iron (3 numbers) and the symmetric soft iron S (9, row-major) such that
S⁻¹ (m − hard_iron) lies on the sphere of the expected field strength.
"""

import sys

import numpy as np


def fit(points: np.ndarray, field: float) -> tuple[np.ndarray, np.ndarray]:
    centre = points.mean(axis=0)
    p = (points - centre) / field
    x, y, z = p.T
    design = np.column_stack([x * x, y * y, z * z, 2 * x * y, 2 * x * z, 2 * y * z, 2 * x, 2 * y, 2 * z, np.ones_like(x)])
    _, _, vt = np.linalg.svd(design, full_matrices=False)
    a, b, c, d, e, f, g, h, i, j = vt[-1]
    quadric = np.array([[a, d, e], [d, b, f], [e, f, c]])
    offset = -np.linalg.solve(quadric, np.array([g, h, i]))
    k = offset @ quadric @ offset - j
    shape = quadric / k
    values, vectors = np.linalg.eigh(shape)
    if np.any(values <= 0):
        sys.exit("not an ellipsoid")
    soft_iron = vectors @ np.diag(values ** -0.5) @ vectors.T
    return centre + offset * field, soft_iron


def main() -> None:
    points = np.loadtxt(sys.argv[1], delimiter=",", skiprows=1)
    hard_iron, soft_iron = fit(points, float(sys.argv[2]))
    print(" ".join(f"{v:.17e}" for v in [*hard_iron, *soft_iron.ravel()]))


if __name__ == "__main__":
    main()
