"""Write the restart files of layout version 1 (before rolling and twisting) that the restart
tests read: run with the plugin of a version-1 checkout (commit cfc27db, `make plugin` there):

    GEOCONTACT_LAMMPS_PLUGIN=/path/to/v1/geocontactplugin.so \
        .venv/bin/python tests/data/make_layout_v1_restarts.py

pair-v1.restart: the slipping pair of test_lammps_plugin.py after PAIR_STEPS steps of its
approach path (plastic, unloading, a tangential force built up); wall-v1.restart: the grain of
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


def wall_interference() -> float:
    return 10 * wall_tests.BASE.for_radius(WALL_RADIUS).yield_approach


def main() -> None:
    lmp = pair_tests.slipping_pair()
    pair_tests.drive_slipping_pair(lmp, pair_tests.approach_path(
        pair_tests.PARAMS.yield_approach)[:PAIR_STEPS])
    lmp.command(f"write_restart {HERE / 'pair-v1.restart'}")
    lmp.close()
    w = wall_interference()
    lmp = wall_tests.grains([WALL_RADIUS], [(0.0, 0.0, WALL_RADIUS - w)], "zplane 0.0 0.5")
    lmp.command("run 1")
    lmp.command(f"write_restart {HERE / 'wall-v1.restart'}")
    lmp.close()


if __name__ == "__main__":
    main()
