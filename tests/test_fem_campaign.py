"""The FE campaign: Dask runs equal direct runs, results are cached by their inputs."""

import time

import numpy as np
import pytest

from geocontact.errors import InputError
from geocontact.fem.campaign import FemJob, load_result, run_campaign
from geocontact.fem.run import run_history
from geocontact.material import load_material

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


@pytest.fixture(scope="module")
def material():
    return load_material("reference")


def test_campaign_matches_direct_runs_and_caches(material, tmp_path):
    jobs = [FemJob(material, (0.0, 20.0, 0.0), steps_per_segment=4),
            FemJob(material, (0.0, 40.0, 0.0), steps_per_segment=4)]
    results = run_campaign(jobs, tmp_path / "cache", workers=2, progress=False)
    direct = run_history(material, [0.0, 40.0, 0.0], steps_per_segment=4, write_fields=False)
    assert np.allclose(results[1].curve["approach_m"], direct.curve["approach_m"], rtol=1e-10)
    assert results[0].summary["cycles"][0]["max_force_N"] == pytest.approx(20.0)
    # every job has its own cache entry, keyed by inputs
    assert len({j.key() for j in jobs}) == 2
    assert all((tmp_path / "cache" / j.key() / "summary.json").exists() for j in jobs)
    again_start = time.perf_counter()
    again = run_campaign(jobs, tmp_path / "cache", progress=False)
    assert time.perf_counter() - again_start < 2.0
    assert np.array_equal(again[0].curve["force_N"], results[0].curve["force_N"])


def test_key_depends_on_every_input(material):
    base = FemJob(material, (0.0, 100.0, 0.0))
    assert base.key() == FemJob(material, (0, 100, 0)).key()
    assert base.key() != FemJob(material, (0.0, 101.0, 0.0)).key()
    assert base.key() != FemJob(material, (0.0, 100.0, 0.0), mesh="default").key()
    assert base.key() != FemJob(material, (0.0, 100.0, 0.0), steps_per_segment=5).key()
    softer = load_material("reference-weak")
    assert base.key() != FemJob(softer, (0.0, 100.0, 0.0)).key()


def test_bad_campaign_input(material, tmp_path):
    with pytest.raises(InputError, match="mesh"):
        FemJob(material, (0.0, 100.0), mesh="huge")
    with pytest.raises(InputError, match="no FE runs"):
        run_campaign([], tmp_path)
    (tmp_path / "broken").mkdir()
    with pytest.raises(InputError, match="unreadable"):
        load_result(tmp_path / "broken")
