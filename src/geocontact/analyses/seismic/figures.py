"""Figures of a seismic run: the scaled records, contact-force histories, force-approach loops."""

from __future__ import annotations

from pathlib import Path

from ...files import atomic_path


def _save(fig, path: Path) -> str:
    """Save atomically (never a half-written figure)."""
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120)
    return path.name


def write_figures(result, out: Path) -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    written = []
    events = result.events
    fig, axes = plt.subplots(len(events), 1, figsize=(8, 2.4 * len(events)), squeeze=False)
    for ax, e in zip(axes[:, 0], events, strict=True):
        rec = e.record
        ax.plot(rec.time, rec.acceleration, lw=0.6, color="k")
        i_peak = int(round(rec.peak_time / rec.dt))
        ax.axvline(rec.peak_time, ls="--", color="C3", alpha=0.6)
        ax.plot(rec.peak_time, rec.acceleration[i_peak], "o", color="C3", ms=4)
        ax.set_ylabel("a (m/s²)")
        ax.set_title(f"{e.label}: {rec.record.name} — PGA {rec.pga:.3g} m/s², peak at "
                     f"{100 * rec.peak_time_fraction:.1f} % of the record → {e.paper_rule}",
                     fontsize=9)
    axes[-1, 0].set_xlabel("time (s)")
    fig.tight_layout()
    written.append(_save(fig, out / "record.png"))
    plt.close(fig)

    h = result.history
    n = result.column.model.spheres
    fig, ax = plt.subplots(figsize=(8, 4))
    for k in range(n):
        ax.plot(h["time"], h["force"][:, k], lw=0.5, label=f"contact {k}")
    for e in events[1:]:
        ax.axvline(e.start, color="grey", ls=":")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("contact force (N)")
    ax.legend(fontsize=7, ncol=min(n, 5))
    ax.set_title("Contact forces (contact 0 is below the top sphere)", fontsize=9)
    fig.tight_layout()
    written.append(_save(fig, out / "force_history.png"))
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(6, 5))
    for k in range(n):
        ax.plot(1e6 * h["approach"][:, k], h["force"][:, k], lw=0.5, label=f"contact {k}")
    ax.scatter(1e6 * result.column.static_approach, result.column.static_force, s=12, c="k",
               zorder=3, label="static start")
    ax.set_xlabel("approach (µm)")
    ax.set_ylabel("contact force (N)")
    ax.legend(fontsize=7)
    ax.set_title("Force–approach loops", fontsize=9)
    fig.tight_layout()
    written.append(_save(fig, out / "loops.png"))
    plt.close(fig)
    return written
