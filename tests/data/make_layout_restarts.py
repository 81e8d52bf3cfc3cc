"""Write the restart files of older layouts that the restart tests read, with the plugin of a
checkout of that layout (`make plugin` there):

    GEOCONTACT_LAMMPS_PLUGIN=/path/to/old/geocontactplugin.so \
        .venv/bin/python tests/data/make_layout_restarts.py VERSION

Version 1 (before rolling and twisting; commit cfc27db): pair-v1.restart and wall-v1.restart.
Version 2 (before the cumulative dissipation tally; commit e6b383e): pair-v2.restart (the wall's
layout did not change).
Version 3 (before the contact radius in the records, when the tangential force was not rescaled
with it; commit 6d76908): pair-v3.restart and wall-v2.restart (the wall's layout version 2).
Version 5 (before the travelled distances of memory with a place; commit 8ae4650):
pair-v5.restart (the pair's own section at its layout version 4; the wall's did not change).
Version 6 (before the due flag of the energy-safe memory reset and the walls' memory; commit
1647bcb): pair-v6.restart (history layout 6, the pair's own section at its layout version 6) and
wall-v4.restart (the wall's layout version 4).

pair-vN.restart: the slipping pair of test_lammps_plugin.py after PAIR_STEPS steps of its
approach path (plastic, unloading, a tangential force built up); wall-vN.restart: the grain of
test_lammps_wall.py pressed 10 wall yield interferences into a zplane 0.0 0.5 wall.
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import test_lammps_plugin as pair_tests  # noqa: E402
import test_lammps_wall as wall_tests  # noqa: E402

PAIR_STEPS = 33
WALL_RADIUS = 0.1
# the wall's layout version at the commit of each pair (history) layout version that wrote one
WALL_LAYOUT = {1: 1, 3: 2, 4: 3, 6: 4}


def wall_interference() -> float:
    return 10 * wall_tests.BASE.for_radius(WALL_RADIUS).yield_approach


def main(version: int) -> None:
    lmp = pair_tests.slipping_pair()
    pair_tests.drive_slipping_pair(lmp, pair_tests.approach_path(
        pair_tests.PARAMS.yield_approach)[:PAIR_STEPS])
    lmp.command(f"write_restart {HERE / f'pair-v{version}.restart'}")
    lmp.close()
    if version not in WALL_LAYOUT:
        return
    w = wall_interference()
    lmp = wall_tests.grains([WALL_RADIUS], [(0.0, 0.0, WALL_RADIUS - w)], "zplane 0.0 0.5")
    lmp.command("run 1")
    lmp.command(f"write_restart {HERE / f'wall-v{WALL_LAYOUT[version]}.restart'}")
    lmp.close()


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 1)
