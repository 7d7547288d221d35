"""Plot of examples/guo21_fig6_error_runtime (Guo21 Fig. 6): GOA vs Lorenz-Mie errors of
(|S1|+|S2|)/2 against r (two measures) and the runtime ratio t_Mie / t_GOA.
Usage: guo21_fig6_error_runtime.py ERROR_CSV PNG RUNTIME_CSV (Debian's /usr/bin/python3 with
matplotlib and numpy)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def read_csv(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    return {k: [float(r[i]) for r in rows[1:]] for i, k in enumerate(rows[0])}


def main(error_csv, png, runtime_csv):
    e = read_csv(error_csv)
    t = read_csv(runtime_csv)
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.2))
    eta = np.array(e['eta'])
    r = np.array(e['r_um'])
    for k, name in enumerate(['relmse', 'energy']):
        for v in sorted(set(eta)):
            s = eta == v
            ax[k].loglog(r[s], np.array(e[name])[s], 'o-', ms=3, label='eta = %g' % v)
        ax[k].axhline(0.01, color='k', lw=0.8, ls='--', label='0.01 (paper)')
        ax[k].axvline(2, color='gray', lw=0.8, ls=':')
        ax[k].set_xlabel('r [um]')
        ax[k].legend(fontsize=8)
    ax[0].set_title('per-angle RelMSE of (|S1|+|S2|)/2')
    ax[1].set_title('energy-weighted error')
    ax[2].loglog(t['r_um'], t['ratio'], 'o-', label='GOA solving rays per call')
    ax[2].loglog(t['r_um'], t['ratio_cached'], 's-', label='GOA, rays cached per angle grid')
    ax[2].set_xlabel('r [um]')
    ax[2].set_ylabel('t_Mie / t_GOA')
    ax[2].legend(fontsize=8)
    ax[2].set_title('runtime ratio (181 angles)')
    fig.suptitle('Guo21 Fig. 6, lambda = 0.6 um')
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2], sys.argv[3])
