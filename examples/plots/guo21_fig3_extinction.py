"""Plot of examples/guo21_fig3_extinction (Guo21 Fig. 3): Q_ext = C_t / (pi r^2) by Lorenz-Mie,
GOA p = 3 (Eq. 12) and GOA p = 1 (Eq. 14). Usage: guo21_fig3_extinction.py CSV PNG (Debian's
/usr/bin/python3 with matplotlib and numpy)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def main(csv_path, png):
    with open(csv_path) as f:
        rows = list(csv.reader(f))
    d = {k: [float(r[i]) for r in rows[1:]] for i, k in enumerate(rows[0])}
    fig, ax = plt.subplots(1, 2, figsize=(13, 4.2))
    for a, lo, hi in [(ax[0], 0.1, 10), (ax[1], 0.1, 100)]:
        r = np.array(d['r_um'])
        s = (r >= lo) & (r <= hi)
        a.plot(r[s], np.array(d['Qext_mie'])[s], 'b-', lw=1, label='Lorenz-Mie')
        a.plot(r[s], np.array(d['Qext_goa_p3'])[s], 'r-', lw=1, label='GOA p = 3 (Eq. 12)')
        a.plot(r[s], np.array(d['Qext_goa_p1'])[s], 'g--', lw=1, label='GOA p = 1 (Eq. 14)')
        a.set_xscale('log')
        a.set_xlabel('r [um]')
        a.set_ylabel('C_t / (pi r^2)')
        a.legend()
    fig.suptitle('Guo21 Fig. 3: extinction, eta = 1.33, lambda = 0.6 um')
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2])
