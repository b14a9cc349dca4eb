"""Every result and campaign pickles (for multiprocessing, Dask, caches) and
comes back equal, NaN and infinities included."""

import copy
import pickle

import numpy as np

import frameid
from conftest import CASE1


def roundtrip(obj):
    return pickle.loads(pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL))


def test_campaign(case1):
    camp, truth = case1
    back = roundtrip(camp)
    assert back == camp and back is not camp
    np.testing.assert_array_equal(back.acc, camp.acc)
    assert back.labels == camp.labels and back.dt_s == camp.dt_s
    assert copy.deepcopy(camp) == camp


def test_truth(case1):
    _, truth = case1
    back = roundtrip(truth)
    assert back == truth and back.to_json() == truth.to_json()


def test_identification_with_error_bars_and_refinement(case1_refined):
    res = case1_refined
    back = roundtrip(res)
    assert back == res
    for name in ("mass", "stiffness", "damping_mkr", "damping_rayleigh", "hankel_singular_values"):
        np.testing.assert_array_equal(getattr(back, name), getattr(res, name))
    assert back.warnings == res.warnings and back.hit_quality == res.hit_quality
    np.testing.assert_array_equal(back.uncertainty.mass_std, res.uncertainty.mass_std)
    np.testing.assert_array_equal(back.refined.damping_std, res.refined.damping_std)
    np.testing.assert_array_equal(back.refined.covariance, res.refined.covariance)
    # The parts pickle on their own.
    m = roundtrip(res.modes[1])
    assert m.frequency_hz == res.modes[1].frequency_hz
    np.testing.assert_array_equal(m.mode_shape, res.modes[1].mode_shape)
    u = roundtrip(res.uncertainty)
    assert u.to_dict() == res.uncertainty.to_dict()
    r = roundtrip(res.refined)
    np.testing.assert_array_equal(r.mass, res.refined.mass)
    rm = roundtrip(res.refined.modes[0])
    assert rm.damping_ratio_std == res.refined.modes[0].damping_ratio_std


def test_missing_parts_and_scores_survive_exactly():
    # Too few hits for error bars: None stays None; sweep scores (NaN for
    # failed trials or refinements) come back bit for bit.
    camp, _ = frameid.simulate(CASE1, hits=2, noise=0.01, seed=1)
    res = frameid.identify(camp)
    back = roundtrip(res)
    assert back.uncertainty is None and back.uncertainty_skipped == res.uncertainty_skipped
    sw = frameid.sweep(CASE1, noise=[0.01], trials=2, seed=1, threads=1)
    scores = sw.scores
    scores_back = roundtrip(sw).scores
    np.testing.assert_array_equal(scores_back, scores)  # NaN == NaN here


def test_bound_and_sweeps():
    b = frameid.bound(CASE1, 0.01)
    back = roundtrip(b)
    assert back.to_dict() == b.to_dict() and back.noise == 0.01
    shard = frameid.sweep(CASE1, noise=[0, 0.01], trials=2, seed=3, shard=(2, 3), threads=1)
    back = roundtrip(shard)
    assert back == shard and back.shard == (2, 3) and back.trials_csv() == shard.trials_csv()
    whole = frameid.sweep(CASE1, noise=[0.01], trials=2, seed=3, threads=1)
    back = roundtrip(whole)
    assert back == whole and back.summary_json() == whole.summary_json()


def test_error_pickles():
    try:
        frameid.identify("not a campaign")
    except frameid.Error as e:
        back = roundtrip(e)
        assert type(back) is frameid.Error and str(back) == str(e)
