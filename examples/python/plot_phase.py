#!/usr/bin/python3
"""Phase function of a water droplet by Lorenz-Mie and GOA through the grainlight Python module.

  PYTHONPATH=build/rel/python /usr/bin/python3 examples/python/plot_phase.py --out out/python_phase

Writes phase.png and phase.csv into --out and prints a JSON summary as the last stdout line.
The index is m = n + i k with k >= 0 absorbing (miepython would write 1.33 - 1e-4j).
"""

import argparse
import json
import math
import os

import numpy as np

import grainlight


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out/python_phase")
    ap.add_argument("--m", type=complex, default=complex(1.33, 1e-4))
    ap.add_argument("--radius-um", type=float, default=10.0)
    ap.add_argument("--wavelength-um", type=float, default=0.55)
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)

    x = 2 * math.pi * args.radius_um / args.wavelength_um
    theta = np.radians(np.linspace(0.0, 180.0, 721))
    mu = np.cos(theta)
    qext, qsca, qback, g = grainlight.mie(args.m, x)
    s1, s2 = grainlight.mie_S1_S2(args.m, x, mu)
    p_mie = (np.abs(s1) ** 2 + np.abs(s2) ** 2) / (2 * math.pi * x * x * qsca)  # 1/sr
    gext, gsca, gabs = grainlight.goa(args.m, x)
    t1, t2 = grainlight.goa_S1_S2(args.m, x, mu)
    p_goa = (np.abs(t1) ** 2 + np.abs(t2) ** 2) / (2 * math.pi * x * x * gsca)
    # Normalization check on a fine theta grid (independent of the plotting grid):
    # 2 pi int p(theta) sin(theta) dtheta = 1.
    tf = np.linspace(0.0, math.pi, 40001)
    a1, a2 = grainlight.mie_S1_S2(args.m, x, np.cos(tf))
    f = (np.abs(a1) ** 2 + np.abs(a2) ** 2) * np.sin(tf) / (2 * math.pi * x * x * qsca)
    norm = 2 * math.pi * float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(tf)))

    with open(os.path.join(args.out, "phase.csv"), "w") as f:
        f.write("theta_deg,phase_mie,phase_goa\n")
        for t, a, b in zip(np.degrees(theta), p_mie, p_goa):
            f.write("%.3f,%.9g,%.9g\n" % (t, a, b))
    png = os.path.join(args.out, "phase.png")
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(7, 4.2))
        ax.semilogy(np.degrees(theta), p_mie, lw=0.8, label="Lorenz-Mie")
        ax.semilogy(np.degrees(theta), p_goa, lw=0.8, label="GOA (p <= 3 + diffraction)")
        ax.set_xlabel("scattering angle [deg]")
        ax.set_ylabel("phase function [1/sr]")
        ax.set_title("water droplet r = %g um, lambda = %g um (x = %.1f), m = %s"
                     % (args.radius_um, args.wavelength_um, x, args.m), fontsize=9)
        ax.legend()
        fig.tight_layout()
        fig.savefig(png, dpi=110)
    except ImportError:
        png = None
    print("Lorenz-Mie: Qext %.6f Qsca %.6f g %.5f; GOA: Qext %.6f Qsca %.6f" % (qext, qsca, g, gext, gsca))
    print(json.dumps({"example": "python_phase", "x": x, "m": [args.m.real, args.m.imag], "qext": qext,
                      "qsca": qsca, "qback": qback, "g": g, "goa_qext": gext, "goa_qsca": gsca,
                      "phase_integral": norm, "png": png}))


if __name__ == "__main__":
    main()
