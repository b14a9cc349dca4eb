"""The package's contract (issue 15): the names and shapes users rely on,
checked against the simulated truth."""

import numpy as np
import pytest

import frameid
from conftest import CASE1


def rel_frobenius(est, true):
    return np.linalg.norm(np.asarray(est) - np.asarray(true)) / np.linalg.norm(true)


def test_simulate_returns_a_campaign_and_its_truth(case1):
    camp, truth = case1
    assert isinstance(camp, frameid.Campaign)
    assert isinstance(truth, frameid.Truth)
    assert camp.hits == len(camp) == 10
    assert camp.force.shape == (10, 1, 2048)
    assert camp.acc.shape == (10, 2, 2048)
    assert camp.dt_s == 1 / 64
    assert camp.inputs == ["force"] and camp.outputs == ["acc1", "acc2"]
    assert truth.mass.shape == truth.stiffness.shape == truth.damping.shape == (2, 2)
    assert truth.settings["campaign"]["noise"]["fraction"] == 0.01
    assert truth.settings["campaign"]["hits"] == 10
    assert len(truth.hits) == 10 and truth.hit_floor == 1
    # Same seed, same campaign: bit for bit.
    again, _ = frameid.simulate(CASE1, hits=10, noise=0.01, seed=1)
    assert again == camp
    other, _ = frameid.simulate(CASE1, hits=10, noise=0.01, seed=2)
    assert not np.array_equal(other.acc, camp.acc)


def test_identify_recovers_m_k_and_damping_with_error_bars(case1, case1_result):
    _, truth = case1
    res = case1_result
    for m in (res.mass, res.stiffness, res.damping_mkr, res.damping_rayleigh):
        assert isinstance(m, np.ndarray) and m.shape == (2, 2) and m.dtype == np.float64
    # README, paper case 1 at 1 % noise over 100 seeds: median relative
    # Frobenius errors 7.6e-4 (M), 4.7e-4 (K), 4.2e-3 (Rayleigh damping),
    # 9.0e-2 (MKR damping). Ten times the median for this one seed.
    assert rel_frobenius(res.mass, truth.mass) < 7.6e-3
    assert rel_frobenius(res.stiffness, truth.stiffness) < 4.7e-3
    assert rel_frobenius(res.damping_rayleigh, truth.damping) < 4.2e-2
    assert rel_frobenius(res.damping_mkr, truth.damping) < 0.9
    # The CLI's defaults: collocated 0:0, band-limited records, error bars.
    assert res.collocated == (0, 0)
    assert res.intersample == "bandlimited"
    assert res.uncertainty is not None and res.uncertainty_skipped is None
    u = res.uncertainty
    assert u.method == "jackknife" and u.hits == 10 and u.groups == 10 and u.resamples == 10
    assert u.mass_std.shape == (2, 2) and np.all(u.mass_std > 0)
    # The error bars cover the truth: within 5 standard errors (4.4e-6
    # two-sided chance for a Gaussian per entry; the jackknife's own spread
    # over 20 seeds is 0.94-1.33 times the true one, tests/uncertainty.rs).
    assert np.all(np.abs(res.mass - truth.mass) < 5 * u.mass_std)
    assert np.all(np.abs(res.stiffness - truth.stiffness) < 5 * u.stiffness_std)


def test_modes(case1, case1_result):
    _, truth = case1
    res = case1_result
    used = [m for m in res.modes if m.used]
    assert len(used) == 2
    assert [res.modes[i] for i in res.used_modes][0].frequency_hz == used[0].frequency_hz
    assert res.modes[0].frequency_hz == pytest.approx(truth.frequencies_hz[0], rel=1e-3)
    for j, m in enumerate(used):
        # README: frequency errors of 1e-5 to 1e-4 at 1 % noise; 1e-3 is ten
        # times the worst. Damping ratios: about 1 % of their value.
        assert m.frequency_hz == pytest.approx(truth.frequencies_hz[j], rel=1e-3)
        assert m.damping_ratio == pytest.approx(truth.damping_ratios[j], rel=0.1)
        assert m.mode_shape.dtype == np.complex128 and m.mode_shape.shape == (2,)
        # Scaled so that the largest component is 1 + 0i.
        assert np.max(np.abs(m.mode_shape)) == 1.0
        assert m.structural and 0.9 < m.mpc <= 1.0 and m.emac is not None
        # The true shapes are real; the identified ones nearly so (MAC > 0.999).
        mac = abs(np.vdot(m.mode_shape, truth.mode_shapes[:, j])) ** 2 / (
            np.vdot(m.mode_shape, m.mode_shape).real
            * np.vdot(truth.mode_shapes[:, j], truth.mode_shapes[:, j]).real
        )
        assert mac > 0.999
    np.testing.assert_array_equal(res.frequencies_hz, [m.frequency_hz for m in used])
    assert res.mode_shapes.shape == (2, 2)


def test_campaign_from_numpy_identifies_as_the_simulated_one(case1, case1_result):
    camp, _ = case1
    again = frameid.Campaign(camp.force, camp.acc, camp.dt_s)
    assert again.inputs == ["force"] and again.outputs == ["acc1", "acc2"]
    assert again.labels == [f"hit {k}" for k in range(1, 11)]
    res = frameid.identify(again, collocated=(0, 0))
    # Same numbers in, same code: the same result, bit for bit.
    np.testing.assert_array_equal(res.mass, case1_result.mass)
    np.testing.assert_array_equal(res.damping_mkr, case1_result.damping_mkr)
    np.testing.assert_array_equal(res.uncertainty.stiffness_std, case1_result.uncertainty.stiffness_std)
    # Lists and integer arrays are converted; names can be given.
    named = frameid.Campaign(
        camp.force.tolist(), camp.acc, 1 / 64, inputs=["F"], outputs=["a", "b"], labels=list("abcdefghij")
    )
    assert named.labels[0] == "a" and named.outputs == ["a", "b"]
    # Channel names select the pair, case-insensitively (as --collocated).
    res = frameid.identify(named, collocated=("A", "f"), uncertainty=False)
    assert res.collocated == (0, 0) and res.outputs == ["a", "b"]
    np.testing.assert_array_equal(res.mass, case1_result.mass)
    # As the command line's --collocated OUT:IN, or any pair.
    assert frameid.identify(named, collocated="a:F", uncertainty=False).collocated == (0, 0)
    assert frameid.identify(named, collocated=[0, "F"], uncertainty=False).collocated == (0, 0)


def test_refine(case1, case1_refined):
    _, truth = case1
    ref = case1_refined.refined
    assert isinstance(ref, frameid.Refined)
    for name in ("mass", "stiffness", "damping", "mass_std", "stiffness_std", "damping_std"):
        a = getattr(ref, name)
        assert isinstance(a, np.ndarray) and a.shape == (2, 2)
    assert np.all(ref.damping_std > 0)
    assert ref.converged and ref.stop in ("Gradient", "Step", "Cost")
    # README at 1 % noise: refined damping 8.4e-3 median error against
    # 9.0e-2 for MKR; the refinement reaches the Cramér–Rao bound.
    assert rel_frobenius(ref.damping, truth.damping) < 8.4e-2
    assert np.all(np.abs(ref.damping - truth.damping) < 5 * ref.damping_std)
    assert np.all(np.abs(ref.mass - truth.mass) < 5 * ref.mass_std)
    assert len(ref.modes) == 2
    assert ref.modes[0].frequency_hz == pytest.approx(truth.frequencies_hz[0], rel=1e-4)
    assert ref.modes[0].frequency_std_hz > 0
    assert ref.noise_outputs.shape == (2,) and ref.noise_inputs.shape == (1,)
    # Without refine=True there is none.
    assert frameid.identify(case1[0], uncertainty=False).refined is None


def test_read_records_like_the_cli(tmp_path, case1):
    camp, truth = case1
    out = tmp_path / "case1"
    sim, t2 = frameid.simulate(CASE1, hits=10, noise=0.01, seed=1, out=out)
    assert sim == camp and t2.hits[0]["file"] == "hit01.csv"
    paths = sorted(str(p) for p in out.glob("hit*.csv"))
    read = frameid.read_records(paths, input="force", outputs=["acc1", "acc2"])
    assert read.labels == paths
    # CSV numbers are written in their shortest round-trip form: the
    # records read back bit for bit.
    np.testing.assert_array_equal(read.force, camp.force)
    np.testing.assert_array_equal(read.acc, camp.acc)
    assert read.dt_s == camp.dt_s
    # Outputs in another order, by comma-separated names, one file.
    swapped = frameid.read_records(paths[0], input="force", outputs="acc2,acc1")
    np.testing.assert_array_equal(swapped.acc[0], camp.acc[0, ::-1])
    # Default outputs: every channel but the inputs, in file order.
    assert frameid.read_records(paths).outputs == ["acc1", "acc2"]


@pytest.mark.parametrize("fmt, rtol", [("uff-binary", 0.0), ("uff", 1e-12)])
def test_read_records_uff(tmp_path, case1, fmt, rtol):
    camp, _ = case1
    out = tmp_path / fmt
    frameid.simulate(CASE1, hits=10, noise=0.01, seed=1, out=out, format=fmt)
    read = frameid.read_records(sorted(out.glob("hit*.uff")), input="#1")
    assert read.inputs == ["force"] and len(read.outputs) == 2
    # Binary UFF holds the doubles; ASCII UFF writes 13 significant digits
    # (E20.12): a relative rounding of at most 5e-13.
    np.testing.assert_allclose(read.acc, camp.acc, rtol=rtol, atol=0)


def test_simulate_overrides_and_acquisition(tmp_path):
    camp, truth = frameid.simulate(CASE1, hits=3, noise=0, seed=5, acquisition="held")
    assert camp.hits == 3 and truth.seed == 5
    assert truth.settings["campaign"]["acquisition"] == {"kind": "held"} or "held" in str(
        truth.settings["campaign"]["acquisition"]
    )
    res = frameid.identify(camp, intersample="zoh", uncertainty=False)
    # Noise-free held records under the exact (ZOH) model: M to round-off
    # of the chain (README: 8e-6 at zero noise; 1e-4 leaves room).
    assert rel_frobenius(res.mass, truth.mass) < 1e-4
    assert res.uncertainty is None and "uncertainty" in res.uncertainty_skipped


def test_hit_quality_and_warnings(case1):
    camp, _ = case1
    force = camp.force.copy()
    # A second hammer pulse on hit 2, half as high, 8 samples after the first.
    peak = int(np.argmax(force[1, 0]))
    force[1, 0, peak + 8 : peak + 12] += 0.5 * force[1, 0, peak - 2 : peak + 2]
    bad = frameid.Campaign(force, camp.acc, camp.dt_s)
    res = frameid.identify(bad, uncertainty=False)
    assert len(res.hit_quality) == 10
    flags = [f["check"] for f in res.hit_quality[1]["flags"]]
    assert "double-hit" in flags
    assert all(not q["flags"] for k, q in enumerate(res.hit_quality) if k != 1)
    assert any(w.startswith("hit 2: double hit") for w in res.warnings), res.warnings
    with pytest.raises(frameid.Error, match="--strict: 1 of 10 hits fail"):
        frameid.identify(bad, strict=True)
    dropped = frameid.identify(bad, drop_bad_hits=True, uncertainty=False)
    assert dropped.dropped_hits == ["hit 2"] and dropped.hits == 9
    assert any(w.startswith("dropped 1 of 10 hits: hit 2") for w in dropped.warnings)


def test_bound_is_the_sweeps_bound():
    b = frameid.bound(CASE1, 0.01, seed=1)
    assert isinstance(b, frameid.Bound)
    # README: about 0.03 % for M and K and 1-2 % for the damping at 1 % noise.
    assert 1e-4 < b.mass < 1e-3 and 1e-4 < b.stiffness < 1e-3 and 5e-3 < b.damping < 3e-2
    assert b.frequencies.shape == b.damping_ratios.shape == (2,)
    sw = frameid.sweep(CASE1, noise=[0.01], trials=1, seed=1, threads=1)
    assert sw.summary["levels"][0]["bound"] == b.to_dict()


def test_sweep_shard_contract():
    sw = frameid.sweep(CASE1, noise=[0, 0.01], trials=50, seed=1, shard=(1, 4), threads=2)
    assert isinstance(sw, frameid.Sweep)
    assert sw.shard == (1, 4) and not sw.complete and sw.summary is None
    # 2 levels x 50 trials dealt round-robin over 4 shards.
    assert len(sw) == 25
    assert sw.scores.shape == (25, len(sw.score_names))
    assert sw.noise_levels == [0.0, 0.01] and sw.trials == 50 and sw.seed == 1
    assert set(sw.status) == {"ok"}
    assert sw.trials_csv().startswith("axis,noise,trial,seed,status,reason,message,f1_err")
    # "k/n" works as well, and the shard is the same.
    again = frameid.sweep(CASE1, noise=np.array([0, 0.01]), trials=np.int64(50), seed=1, shard="1/4", threads=1)
    assert again == sw
    # One level may be given as a number.
    assert frameid.sweep(CASE1, noise=0.01, trials=2, shard=(1, 2), threads=1).noise_levels == [0.01]


def test_sweep_summary_and_report(tmp_path):
    sw = frameid.sweep(CASE1, noise=[0, 0.01], trials=3, seed=1, threads=2, out=tmp_path / "sweep")
    assert sw.complete and sw.path == str(tmp_path / "sweep")
    s = sw.summary
    assert [lvl["noise"] for lvl in s["levels"]] == [0.0, 0.01]
    assert s["levels"][0]["bound"] is None and s["levels"][1]["bound"] is not None
    mass_err = sw.column("mass_err")
    assert mass_err.shape == (6,) and np.all(mass_err[3:] < 1e-2)
    html = frameid.report([sw], tmp_path / "r.html", title="case 1 from Python")
    text = open(html, encoding="utf-8").read()
    assert "case 1 from Python" in text and "<svg" in text


def test_excitation_modes_and_band_as_on_the_command_line(case1, case1_result):
    camp, _ = case1
    # Hammer records of a 2-DOF frame: every structural mode is used.
    assert case1_result.mode_selection == "all-structural"
    assert case1_result.out_of_model_modes == []
    assert all(q["excitation"] == "hammer" for q in case1_result.hit_quality)
    # The modes nearest 2.7 and 9.2 Hz are the same two modes: same model.
    near = frameid.identify(camp, uncertainty=False, modes=[2.7, 9.2])
    assert near.mode_selection == "near"
    np.testing.assert_array_equal(near.mass, case1_result.mass)
    band = frameid.identify(camp, uncertainty=False, band=(1.0, 12.0))
    assert band.mode_selection == "band"
    # A band holding one mode, both choices at once, an unknown excitation:
    # frameid.Error naming the keyword or the band.
    with pytest.raises(frameid.Error, match="the band 5-8 Hz holds 0 structural mode"):
        frameid.identify(camp, uncertainty=False, band=(5.0, 8.0))
    with pytest.raises(frameid.Error, match="modes and band: choose one"):
        frameid.identify(camp, modes=[2.7, 9.2], band=(1.0, 12.0))
    with pytest.raises(frameid.Error, match="excitation: unknown excitation 'pendulum'"):
        frameid.identify(camp, excitation="pendulum")


def test_decimate_and_initial_state_as_on_the_command_line(case1):
    camp, truth = case1
    # 64 Hz records of modes below 10 Hz: identified at their own rate by
    # default, so nothing is reported.
    plain = frameid.identify(camp, uncertainty=False)
    assert plain.decimation is None and plain.initial_state is None
    # A given factor: 32 Hz, still 3.2 times the second mode (9.2 Hz).
    halved = frameid.identify(camp, uncertainty=False, decimate=2)
    d = halved.decimation
    assert d["factor"] == 2 and d["chosen"] == "given"
    assert d["original_rate_hz"] == 64.0 and d["rate_hz"] == 32.0
    # README: 7.6e-4 median M error at 1 % noise at the full rate; ten times
    # that bounds the decimated campaign as well (same data, half the
    # equations, the anti-alias filter's pass band ends at 12.8 Hz).
    assert rel_frobenius(halved.mass, truth.mass) < 7.6e-3
    # "off" is a choice, reported as on the command line: factor 1, given.
    off = frameid.identify(camp, uncertainty=False, decimate="off").decimation
    assert off["factor"] == 1 and off["chosen"] == "given"
    unknown = frameid.identify(camp, uncertainty=False, initial_state="unknown")
    assert unknown.initial_state is not None
    assert unknown.initial_state["chosen"] == "given"
    assert rel_frobenius(unknown.mass, truth.mass) < 7.6e-3
    with pytest.raises(frameid.Error, match="decimate: expected auto, off or a decimation factor"):
        frameid.identify(camp, decimate="fast")
    with pytest.raises(frameid.Error, match="decimate: expected"):
        frameid.identify(camp, decimate=0)
    with pytest.raises(TypeError, match="decimate"):
        frameid.identify(camp, decimate=[2])
    with pytest.raises(frameid.Error, match="initial_state: expected auto, at-rest or unknown"):
        frameid.identify(camp, initial_state="sleeping")


def test_keep_awake_switch_changes_no_number(case1, case1_refined):
    # The second thread kept awake during a call only changes when the work
    # is done: switched off, the identification and the refinement are the
    # same numbers bit for bit.
    camp, _ = case1
    assert frameid.keep_awake()
    frameid.set_keep_awake(False)
    try:
        assert not frameid.keep_awake()
        again = frameid.identify(camp, refine=True)
    finally:
        frameid.set_keep_awake(True)
    assert frameid.keep_awake()
    for name in ("mass", "stiffness", "damping_mkr"):
        assert np.array_equal(getattr(again, name), getattr(case1_refined, name))
    for name in ("mass", "stiffness", "damping", "mass_std"):
        assert np.array_equal(getattr(again.refined, name), getattr(case1_refined.refined, name))
