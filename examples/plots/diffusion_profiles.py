"""Plot of examples/diffusion_profiles: R(r) / T(r) of the Monte Carlo walk against the dipole,
improved diffusion and multipole models. Usage: diffusion_profiles.py CSV PNG (Debian's
/usr/bin/python3 with matplotlib)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def read_csv(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    head = rows[0]
    return {k: np.array([float(r[i]) for r in rows[1:]]) for i, k in enumerate(head)}


def main(csv_path, png):
    cols = read_csv(csv_path)
    fig, axes = plt.subplots(2, 3, figsize=(14, 8.5))
    panels = [(0, 0), (1, 0), (2, 0), (3, 0), (4, 0), (4, 1)]
    for ax, (ci, face) in zip(axes.flat, panels):
        m = (cols['case'] == ci) & (cols['face'] == face)
        if not m.any():
            continue
        aa, gg, B = cols['albedo'][m][0], cols['g'][m][0], cols['optical_depth'][m][0]
        st = aa * (1 - gg) + (1 - aa)
        scale = 1.0 / st**2  # profiles in units of sigma_t'^2
        x = cols['r_reduced'][m]
        ax.errorbar(x, cols['mc'][m] * scale, yerr=cols['mc_stderr'][m] * scale, fmt='k.', ms=3,
                    label='Monte Carlo (walk kernel)')
        if face == 0:
            ax.loglog(x, cols['dipole'][m] * scale, label='classical dipole (half-space)')
            ax.loglog(x, cols['improved'][m] * scale, label='improved / PBD (half-space)')
        ax.loglog(x, cols['multipole_classical'][m] * scale, ':', label='multipole, classical')
        ax.loglog(x, cols['multipole_improved'][m] * scale, '--', label='multipole, improved')
        geo = f'slab B = {B:g}' if B > 0 else "half-space (multipole d = 50 mfp')"
        q = 'R' if face == 0 else 'T'
        ax.set_title(f"{q}(r): albedo {aa}, g = {gg}, {geo}", fontsize=9)
        ax.set_xlabel("r sigma_t'")
        ax.set_ylabel(f"{q}(r) / sigma_t'^2")
        ax.set_ylim(1e-7, 1e2)
        ax.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2])
