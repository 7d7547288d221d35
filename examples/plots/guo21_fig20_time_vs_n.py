"""Plot of examples/guo21_fig20_time_vs_n (Guo21 Fig. 20): CPU seconds of EPT and ours against N,
and the ratios EPT / ours at equal spp and per unit variance. Usage: guo21_fig20_time_vs_n.py CSV PNG
(Debian's /usr/bin/python3 with matplotlib)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402


def main(csv_path, png):
    with open(csv_path) as f:
        rows = list(csv.DictReader(f))
    n = [float(r['N']) for r in rows]
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    ax[0].loglog(n, [float(r['cpu_seconds_ept']) for r in rows], 'ko-', label='EPT (explicit spheres)')
    ax[0].loglog(n, [float(r['cpu_seconds_discrete']) for r in rows], 'bs-', label='ours')
    ax[0].loglog(n, [float(r['cpu_seconds_discrete_no_diffraction']) for r in rows], 'g^--', label='ours -FD')
    ax[0].set_xlabel('N')
    ax[0].set_ylabel('render CPU seconds (equal spp)')
    ax[0].legend()
    ax[1].semilogx(n, [float(r['time_ratio']) for r in rows], 'bs-', label='EPT / ours, equal spp')
    ax[1].semilogx(n, [float(r['ttuv_speedup']) for r in rows], 'ro-', label='EPT / ours, time to unit variance')
    ax[1].semilogx([1e5, 1e6], [1.2, 2.0], 'kx', markersize=10, label='paper (Table 1, Fig. 20)')
    ax[1].axhline(1.0, color='gray', lw=0.5)
    ax[1].set_xlabel('N')
    ax[1].set_ylabel('speed-up')
    ax[1].legend()
    fig.suptitle('Guo21 Fig. 20: render time vs particle count (Cornell box, 1000 um)')
    fig.tight_layout()
    fig.savefig(png, dpi=120)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2])
