"""Plot of examples/guo21_fig19_psd (Guo21 Fig. 19): per PSD, the mean radiance of the discrete
medium and its continuous pair, the graininess (per-pixel RMS difference to the continuous pair /
its mean) and the asymmetry parameter g. Usage: guo21_fig19_psd.py CSV PNG (Debian's
/usr/bin/python3 with matplotlib)."""
import csv
import sys

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402


def main(csv_path, png):
    with open(csv_path) as f:
        rows = list(csv.DictReader(f))
    names = [r['case'] for r in rows]
    x = list(range(len(rows)))
    col = lambda k: [float(r[k]) for r in rows]  # noqa: E731
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.5))
    ax[0].plot(x, col('mean_discrete'), 'bo', label='ours (discrete medium)')
    ax[0].plot(x, col('mean_continuous'), 'rs', mfc='none', label='continuous pair (sum C_t / V)')
    ax[0].plot(x, col('mean_continuous_membership'), 'gx', label='continuous, membership-scaled')
    ax[0].set_yscale('log')
    ax[0].set_ylabel('mean radiance')
    ax[0].legend()
    ax[1].plot(x, col('graininess'), 'ko-', label='graininess (MC noise removed)')
    ax[1].plot(x, col('discrete_noise'), 'b:', label='discrete render MC noise')
    ax[1].plot(x, col('continuous_noise'), 'r:', label='continuous render MC noise')
    ax[1].set_ylabel('per-pixel RMS / mean')
    ax[1].legend()
    ax[2].plot(x, col('g'), 'go', label='rendered particles')
    ax[2].plot(x, col('g_bulk_with_diffraction'), 'm^', label='bulk PSD with diffraction')
    ax[2].set_ylabel('asymmetry parameter g')
    ax[2].legend()
    for a in ax:
        a.set_xticks(x)
        a.set_xticklabels(names, rotation=45, ha='right', fontsize=8)
    fig.suptitle('Guo21 Fig. 19: impact of the global PSD')
    fig.tight_layout()
    fig.savefig(png, dpi=120)


if __name__ == '__main__':
    main(sys.argv[1], sys.argv[2])
