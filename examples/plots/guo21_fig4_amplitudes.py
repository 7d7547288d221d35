"""Plot of examples/guo21_fig4_amplitudes (Guo21 Fig. 4): log10 |S1| and log10 |S2| by Lorenz-Mie
and GOA at r = 0.1, 1, 2, 10, 100 um. Usage: guo21_fig4_amplitudes.py CSV PNG (Debian's
/usr/bin/python3 with matplotlib)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402


def main(csv_path, png):
    with open(csv_path) as f:
        rows = list(csv.reader(f))
    d = {k: [float(r[i]) for r in rows[1:]] for i, k in enumerate(rows[0])}
    tags = ['0.1', '1', '2', '10', '100']
    fig, ax = plt.subplots(2, 5, figsize=(20, 6.5))
    for k, t in enumerate(tags):
        for row, j in [(0, 1), (1, 2)]:
            ax[row][k].plot(d['theta_deg'], d['logS%d_mie_r%s' % (j, t)], 'b-', lw=0.8, label='Lorenz-Mie')
            ax[row][k].plot(d['theta_deg'], d['logS%d_goa_r%s' % (j, t)], 'r-', lw=0.8, label='GOA')
            ax[row][k].set_title('log10 |S%d|, r = %s um' % (j, t))
            ax[row][k].set_xlabel('theta [deg]')
            ax[row][k].legend(fontsize=7)
    fig.suptitle('Guo21 Fig. 4: eta = 1.33, lambda = 0.6 um')
    fig.tight_layout()
    fig.savefig(png, dpi=100)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2])
