"""Plot of examples/guo21_fig16_query_radius (Guo21 Fig. 16): mean radiance of the discrete medium
against k of Eq. 23 beside the membership rule's prediction (the factor-scaled continuous medium),
and the graininess against k. Usage: guo21_fig16_query_radius.py CSV PNG (Debian's
/usr/bin/python3 with matplotlib)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402


def main(csv_path, png):
    with open(csv_path) as f:
        rows = list(csv.DictReader(f))
    k = [float(r['k']) for r in rows]
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    ax[0].semilogx(k, [float(r['mean_discrete']) for r in rows], 'bo-', label='ours (discrete medium)')
    ax[0].semilogx(k, [float(r['mean_predicted']) for r in rows], 'rs--', label='membership-rule prediction')
    ax[0].set_xlabel('k (Eq. 23)')
    ax[0].set_ylabel('mean radiance')
    ax[0].legend()
    ax[1].semilogx(k, [float(r['graininess']) for r in rows], 'ko-', label='graininess (noise removed)')
    ax[1].semilogx(k, [float(r['membership_factor']) - 1 for r in rows], 'g^--', label='membership factor - 1')
    ax[1].set_xlabel('k (Eq. 23)')
    ax[1].legend()
    fig.suptitle('Guo21 Fig. 16: query cylinder cross section')
    fig.tight_layout()
    fig.savefig(png, dpi=120)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2])
