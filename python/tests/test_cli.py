"""The package agrees with the command line on the same records: the numbers
of ``frameid identify --json`` (bit for bit: the same library code runs on
the same samples, and the JSON numbers are shortest round-trip decimals),
the files of ``frameid simulate`` and of ``frameid sweep`` (byte for byte)."""

import filecmp
import json

import numpy as np
import pytest

import frameid
from conftest import CASE1, CASE1_REALIZATION, REPO


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    """Paper case 1 written by the command line: 10 hits at 1 % noise."""
    return tmp_path_factory.mktemp("cli") / "case1"


def simulate_cli(cli, out, *flags):
    code, stdout, stderr = cli("simulate", CASE1, "--out", out, "--noise", "0.01", "--seed", "7", *flags)
    assert code == 0, stderr
    return sorted(str(p) for p in out.glob("hit*.*") if p.suffix in (".csv", ".uff"))


def identify_cli(cli, files, *flags):
    code, stdout, stderr = cli("identify", *files, "--json", *flags)
    assert code == 0, stderr
    return json.loads(stdout)


def same(array, rows):
    np.testing.assert_array_equal(np.asarray(array), np.asarray(rows))


def check_modes(res, doc):
    assert len(res.modes) == len(doc["modes"])
    for mode, m in zip(res.modes, doc["modes"]):
        assert mode.frequency_hz == m["frequency_hz"]
        assert mode.damping_ratio == m["damping_ratio"]
        same(mode.mode_shape, [complex(re, im) for re, im in m["mode_shape"]])
        for key in ("emac", "emac_output", "emac_input", "mpc", "msv", "cmi", "structural", "used"):
            assert getattr(mode, key) == m[key], key


def check_identification(res, doc):
    for key in ("mass", "stiffness", "damping_mkr", "damping_rayleigh"):
        same(getattr(res, key), doc[key])
    check_modes(res, doc)
    assert res.rayleigh_alpha == doc["rayleigh"]["alpha"]
    assert res.rayleigh_beta == doc["rayleigh"]["beta"]
    assert res.consistency == doc["consistency"]
    assert res.model_order == doc["model_order"]
    assert res.intersample == doc["intersample"]
    assert res.polarity_flipped == doc["polarity_flipped"]
    assert res.warnings == doc["warnings"]
    assert res.observer == doc["observer"]
    same(res.hankel_singular_values, doc["hankel_singular_values"])
    src = doc["source"]
    assert res.files == src["files"] and res.inputs == src["inputs"] and res.outputs == src["outputs"]
    assert res.dt_s == src["dt_s"] and res.hits == src["hits"] and res.samples == src["samples"]
    assert res.collocated == (src["collocated"]["output"], src["collocated"]["input"])
    assert res.from_realization == src["realization"]


def test_identify_agrees_with_the_cli(cli, records):
    files = simulate_cli(cli, records)
    doc = identify_cli(cli, files)
    res = frameid.identify(frameid.read_records(files))
    check_identification(res, doc)
    assert res.hit_quality == doc["hit_quality"]
    assert res.inconsistent_hits == doc["inconsistent_hits"] == []
    assert res.consistency_notes == doc["consistency_notes"]
    assert res.dropped_hits == doc["dropped_hits"]
    assert res.uncertainty.to_dict() == doc["uncertainty"]
    assert res.uncertainty_skipped == doc["uncertainty_skipped"]
    same(res.uncertainty.mass_std, doc["uncertainty"]["mass"]["std"])
    same(res.uncertainty.frequencies_hz_std, doc["uncertainty"]["frequencies_hz"]["std"])


def test_inconsistent_hits_agree_with_the_cli(cli, records, tmp_path):
    """A record given twice and a spiked sample: flagged, dropped and named
    by file and line as the command line does."""
    files = sorted(str(p) for p in records.glob("hit*.csv"))
    if not files:
        files = simulate_cli(cli, records)
    lines = open(files[3], encoding="utf-8").read().splitlines()
    cells = lines[400].split(",")
    cells[2] = str(float(cells[2]) + 50.0)  # a spike on acc1 at line 401
    lines[400] = ",".join(cells)
    spiked = tmp_path / "spiked.csv"
    spiked.write_text("\n".join(lines) + "\n", encoding="utf-8")
    given = [*files[:3], str(spiked), *files[4:], files[0]]
    doc = identify_cli(cli, given)
    res = frameid.identify(frameid.read_records(given))
    assert doc["inconsistent_hits"], doc["warnings"]
    assert res.inconsistent_hits == doc["inconsistent_hits"]
    assert res.consistency_notes == doc["consistency_notes"]
    assert res.dropped_hits == doc["dropped_hits"]
    assert res.warnings == doc["warnings"]
    check_identification(res, doc)
    # The pickled campaign keeps the lines of its files.
    import pickle

    again = frameid.identify(pickle.loads(pickle.dumps(frameid.read_records(given))))
    assert again.warnings == doc["warnings"]


def test_identify_with_options_agrees_with_the_cli(cli, records):
    files = sorted(str(p) for p in records.glob("hit*.csv"))
    if not files:
        files = simulate_cli(cli, records)
    doc = identify_cli(
        cli, files, "--outputs", "acc1,acc2", "--collocated", "acc1:force", "--intersample", "zoh",
        "--no-uncertainty", "--refine", "--parametrization", "shear-frame",
    )
    camp = frameid.read_records(files, input="force", outputs=["acc1", "acc2"])
    res = frameid.identify(
        camp, collocated=("acc1", "force"), intersample="zoh", uncertainty=False, refine=True,
        parametrization="shear-frame",
    )
    check_identification(res, doc)
    assert res.uncertainty is None and doc["uncertainty"] is None
    assert res.uncertainty_skipped == doc["uncertainty_skipped"]
    ref, r = res.refined, doc["refined"]
    for key in ("mass", "stiffness", "damping", "mass_std", "stiffness_std", "damping_std"):
        same(getattr(ref, key), r[key])
    same(ref.noise_outputs, r["noise_outputs"])
    same(ref.noise_inputs, r["noise_inputs"])
    assert (ref.iterations, ref.stop, ref.converged) == (r["iterations"], r["stop"], r["converged"])
    assert (ref.initial_cost, ref.cost) == (r["initial_cost"], r["cost"])
    for mode, m in zip(ref.modes, r["modes"], strict=True):
        assert (mode.frequency_hz, mode.frequency_std_hz) == (m["frequency_hz"], m["frequency_std_hz"])
        assert (mode.damping_ratio, mode.damping_ratio_std) == (m["damping_ratio"], m["damping_ratio_std"])
        same(mode.mode_shape, [complex(re, im) for re, im in m["mode_shape"]])


def test_identify_realization_agrees_with_the_cli(cli):
    doc = identify_cli(cli, [], "--realization", CASE1_REALIZATION, "--intersample", "zoh")
    res = frameid.identify_realization(CASE1_REALIZATION, intersample="zoh")
    check_identification(res, doc)
    # The paper's case 1 (eq. 37): m11 = 0.2913 kg from its realization.
    assert res.mass[0, 0] == pytest.approx(0.2913, abs=1e-3)
    assert res.realization["a"].shape == (4, 4) and res.hits == 0 and res.uncertainty is None


def test_simulate_writes_what_the_cli_writes(cli, tmp_path):
    for fmt in ("csv", "uff-binary"):
        cli_dir, py_dir = tmp_path / f"cli-{fmt}", tmp_path / f"py-{fmt}"
        simulate_cli(cli, cli_dir, "--hits", "3", "--format", fmt)
        frameid.simulate(CASE1, hits=3, noise=0.01, seed=7, out=py_dir, format=fmt)
        names = sorted(p.name for p in cli_dir.iterdir())
        assert names == sorted(p.name for p in py_dir.iterdir())
        assert "truth.json" in names
        match, mismatch, errors = filecmp.cmpfiles(cli_dir, py_dir, names, shallow=False)
        assert mismatch == [] and errors == [], (fmt, mismatch, errors)


def test_sweep_writes_what_the_cli_writes(cli, tmp_path, monkeypatch):
    scenario = "scenarios/paper-case1.toml"  # as given: recorded in sweep.json
    code, _, err = cli("sweep", scenario, "--out", tmp_path / "cli", "--noise", "0,0.01", "--trials", "3",
                       "--seed", "4", "--threads", "2")
    assert code == 0, err
    monkeypatch.chdir(REPO)
    sw = frameid.sweep(scenario, noise=[0, 0.01], trials=3, seed=4, threads=1, out=tmp_path / "py")
    names = sorted(p.name for p in (tmp_path / "cli").iterdir())
    assert names == ["representative.json", "summary.json", "sweep.json", "trials.csv"]
    match, mismatch, errors = filecmp.cmpfiles(tmp_path / "cli", tmp_path / "py", names, shallow=False)
    assert mismatch == [] and errors == []
    assert sw.summary_json() == (tmp_path / "cli" / "summary.json").read_text(encoding="utf-8")
    # The command line merges shards the package wrote.
    for k in (1, 2):
        frameid.sweep(CASE1, noise=[0.01], trials=3, seed=4, shard=(k, 2), threads=1, out=tmp_path / f"s{k}")
    code, _, err = cli("merge", tmp_path / "s1", tmp_path / "s2", "--out", tmp_path / "m")
    assert code == 0, err
    whole = frameid.sweep(CASE1, noise=[0.01], trials=3, seed=4, threads=1)
    assert (tmp_path / "m" / "trials.csv").read_text(encoding="utf-8") == whole.trials_csv()
    assert (tmp_path / "m" / "summary.json").read_text(encoding="utf-8") == whole.summary_json()


def test_compare_returns_what_the_cli_writes(cli, tmp_path, monkeypatch):
    monkeypatch.chdir(REPO)
    # 8 trials: the fewest with a median's Monte Carlo error.
    a = frameid.sweep(CASE1, noise=[0.01], trials=8, seed=4, threads=1, out=tmp_path / "a")
    b = frameid.sweep(CASE1, noise=[0.01], trials=8, seed=5, threads=1)
    got = frameid.compare(a, b, ignore=["refine_iterations"])
    b.write(tmp_path / "b")
    code, out, err = cli("compare", tmp_path / "a", tmp_path / "b", "--ignore", "refine_iterations", "--json")
    assert code in (0, 1), err
    assert got == json.loads(out)
    assert got["cells"] == 1 and got["compared"] > 0 and got["ignored"] == ["refine_iterations"]
    # The same sweep as an object and as its directory: every difference is zero.
    same = frameid.compare(a, tmp_path / "a", threshold=1e-9)
    assert same["changed"] == [] and same["largest"]["z"] == 0.0
    shard = frameid.sweep(CASE1, noise=[0.01], trials=8, seed=4, shard=(1, 2), threads=1)
    with pytest.raises(frameid.Error, match="a shard has no summary; merge the shards first"):
        frameid.compare(a, shard)
    with pytest.raises(frameid.Error, match="threshold -1: must be a positive number"):
        frameid.compare(a, b, threshold=-1)


def test_merge_refuses_shards_of_another_version(tmp_path, monkeypatch):
    monkeypatch.chdir(REPO)
    for k in (1, 2):
        frameid.sweep(CASE1, noise=[0.01], trials=2, seed=4, shard=(k, 2), threads=1, out=tmp_path / f"s{k}")
    manifest = tmp_path / "s2" / "sweep.json"
    m = json.loads(manifest.read_text(encoding="utf-8"))
    m["frameid_version"] = "0.0.1"
    manifest.write_text(json.dumps(m), encoding="utf-8")
    # In memory (the package's own join) and written out (the command line's).
    for out in (None, tmp_path / "m"):
        with pytest.raises(frameid.Error, match=r"written by frameid 0\.0\.1"):
            frameid.merge([tmp_path / "s1", tmp_path / "s2"], out=out)
    assert not (tmp_path / "m").exists()
