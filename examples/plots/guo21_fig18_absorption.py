"""Plot of examples/guo21_fig18_absorption (Guo21 Fig. 18): bulk single-scattering albedo and mean
radiance (discrete medium and its continuous pair) against the imaginary part eta_i of the particle
index (eta_r = 1.5). Usage: guo21_fig18_absorption.py CSV PNG (Debian's /usr/bin/python3 with
matplotlib)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402


def main(csv_path, png):
    with open(csv_path) as f:
        rows = list(csv.DictReader(f))
    eta = [float(r['eta_i']) for r in rows]
    # eta_i = 0 on a log axis: place it one decade below the smallest positive value.
    pos = [e for e in eta if e > 0]
    floor = min(pos) / 10 if pos else 1e-6
    x = [e if e > 0 else floor for e in eta]
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    ax[0].semilogx(x, [float(r['albedo']) for r in rows], 'ko-', label='rendered particles')
    ax[0].semilogx(x, [float(r['albedo_bulk_with_diffraction']) for r in rows], 'g^--',
                   label='bulk PSD with diffraction (Eq. 16)')
    ax[0].set_xlabel('eta_i (leftmost point: 0)')
    ax[0].set_ylabel('single-scattering albedo')
    ax[0].legend()
    ax[1].semilogx(x, [float(r['mean_discrete']) for r in rows], 'bo-', label='ours (discrete medium)')
    ax[1].semilogx(x, [float(r['mean_continuous']) for r in rows], 'rs--', label='continuous pair')
    ax[1].set_xlabel('eta_i (leftmost point: 0)')
    ax[1].set_ylabel('mean radiance')
    ax[1].legend()
    fig.suptitle('Guo21 Fig. 18: absorbing particles, eta = 1.5 + i eta_i')
    fig.tight_layout()
    fig.savefig(png, dpi=120)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2])
