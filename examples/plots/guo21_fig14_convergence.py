"""Plot of examples/guo21_fig14_convergence (Guo21 Fig. 14): mean-radiance difference and
per-pixel RMS difference of each discrete medium to its paired continuous medium against N.
Usage: guo21_fig14_convergence.py CSV PNG (Debian's /usr/bin/python3 with matplotlib)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402


def main(csv_path, png):
    with open(csv_path) as f:
        rows = list(csv.reader(f))
    d = {k: [float(r[i]) for r in rows[1:]] for i, k in enumerate(rows[0])}
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    ax[0].semilogx(d['N'], [100 * v for v in d['rel_diff']], 'bo-')
    ax[0].axhline(0, color='k', lw=0.5)
    ax[0].set_xlabel('N')
    ax[0].set_ylabel('mean radiance: discrete / continuous - 1 [%]')
    ax[1].loglog(d['N'], d['rel_rmse'], 'ro-', label='discrete vs continuous')
    ax[1].loglog(d['N'], d['continuous_noise_rmse'], 'k--', label='continuous vs continuous (noise)')
    ax[1].set_xlabel('N')
    ax[1].set_ylabel('per-pixel RMS / mean')
    ax[1].legend()
    fig.suptitle('Guo21 Fig. 14: discrete media converge to the paired continuous media')
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2])
