"""Plot of examples/guo21_fig11_diffraction_share (Guo21 Fig. 11): the share of the scattered
energy carried by Fraunhofer diffraction against the angle, at r = 2, 20, 1000 um.
Usage: guo21_fig11_diffraction_share.py CSV PNG (Debian's /usr/bin/python3 with matplotlib)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402


def main(csv_path, png):
    with open(csv_path) as f:
        rows = list(csv.reader(f))
    d = {k: [float(r[i]) for r in rows[1:]] for i, k in enumerate(rows[0])}
    fig, ax = plt.subplots(1, 3, figsize=(15, 4))
    for a, r in zip(ax, [2, 20, 1000]):
        a.semilogx(d['theta_deg'], [100 * v for v in d['share_r%d' % r]], 'b-')
        a.set_ylim(-2, 102)
        a.set_title('r = %d um' % r)
        a.set_xlabel('theta [deg]')
    ax[0].set_ylabel('diffraction share of energy [%]')
    fig.suptitle('Guo21 Fig. 11: Fraunhofer diffraction share (ice, lambda = 0.55 um)')
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2])
