"""Measured scatter on the bundled blades: what the seam rule and the scatter estimate read.

Run ``python benchmarks/scatter_traits.py`` (a few seconds). For each bundled blade and a
Gaussian scatter of 0, 1, 2, 3 and 5 um on every coordinate (``--seeds`` draws, seeded so
the figures repeat), it prints:

- **open**: sections the seam rule (:func:`toolpath.closure.read_seam`) reads open, of all
  the sections drawn. The DCA rotor and the propeller are closed, the blunt rotor and the
  development blade open (a blunt trailing-edge base);
- **scatter**: the median over the draws of :func:`toolpath.scatter.sections_scatter_mm`,
  in um (it should read the scatter added; ~0 on the exact points).

Before the seam rule set the scatter aside (the parent of fbc0c60), the DCA rotor read
0 / 16 / 61 / 126 of 220 sections open at 1 / 2 / 3 / 5 um (20 seeds).
"""

from __future__ import annotations

import argparse

import numpy as np

from toolpath.closure import read_seam
from toolpath.paper_examples import bundled_data_path
from toolpath.pointio import read_sections
from toolpath.scatter import sections_scatter_mm

BLADES = ("dev_rotor_dca_11x181", "dev_prop_7x100", "dev_rotor_blunt_9x120",
          "dev_blade_15x142")
SCATTER_UM = (0.0, 1.0, 2.0, 3.0, 5.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20, help="draws per scatter (20)")
    args = parser.parse_args()
    print(f"{'blade':24s} " + "  ".join(f"{um:g} um: open, scatter" for um in SCATTER_UM))
    for name in BLADES:
        sections = read_sections(bundled_data_path(f"{name}.csv"))
        cells = []
        for um in SCATTER_UM:
            opened = total = 0
            estimates = []
            for seed in range(args.seeds if um else 1):
                rng = np.random.default_rng(seed)
                drawn = [p + rng.normal(0.0, 1e-3 * um, p.shape) for p in sections]
                opened += sum(not read_seam(p).closed for p in drawn)
                total += len(drawn)
                estimates.append(sections_scatter_mm(drawn))
            cells.append(f"{opened}/{total}, {1e3 * float(np.median(estimates)):.2f}")
        print(f"{name:24s} " + "  ".join(f"{c:>20s}" for c in cells))


if __name__ == "__main__":
    main()
