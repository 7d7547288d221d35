"""Plot of examples/guo21_fig2_orders (Guo21 Fig. 2): GOA (|S1|+|S2|)/2 for p <= 1, 2, 3, 100 at
r = 2, 10, 100 um. Usage: guo21_fig2_orders.py CSV PNG (Debian's /usr/bin/python3 with
matplotlib)."""
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
    for k, r in enumerate([2, 10, 100]):
        for p, st in zip([1, 2, 3, 100], [':', '-.', '-', '--']):
            ax[k].semilogy(d['theta_deg'], d['F_r%d_p%d' % (r, p)], st, lw=1, label='p <= %d' % p)
        ax[k].set_title('r = %d um' % r)
        ax[k].set_xlabel('scattering angle [deg]')
        ax[k].legend()
    ax[0].set_ylabel('(|S1|+|S2|)/2 (GOA)')
    fig.suptitle('Guo21 Fig. 2: impact of p, eta = 1.33, lambda = 0.6 um')
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2])
