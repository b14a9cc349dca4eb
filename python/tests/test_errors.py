"""Bad input raises frameid.Error (a ValueError) with the message the
command line prints, never a crash."""

import json

import numpy as np
import pytest

import frameid
from conftest import CASE1


def cli_message(cli, *args):
    """The message of a failing ``frameid ARGS`` (stderr without ``error: ``)."""
    code, out, err = cli(*args)
    assert code == 2, (code, out, err)
    assert err.startswith("error: "), err
    return err[len("error: ") :].rstrip("\n")


def py_message(f, *args, **kwargs):
    with pytest.raises(frameid.Error) as info:
        f(*args, **kwargs)
    assert isinstance(info.value, ValueError)
    return str(info.value)


@pytest.fixture(scope="module")
def hits(tmp_path_factory):
    """Paper case 1 records (CSV), 4 hits at 1 % noise."""
    out = tmp_path_factory.mktemp("records") / "case1"
    frameid.simulate(CASE1, hits=4, noise=0.01, seed=1, out=out)
    return sorted(str(p) for p in out.glob("hit*.csv"))


def write(path, text):
    path.write_text(text, encoding="utf-8")
    return str(path)


def test_record_file_errors_match_the_cli(cli, hits, tmp_path):
    bad = {
        "missing": str(tmp_path / "absent.csv"),
        "nan": write(tmp_path / "nan.csv", "time,force,acc1,acc2\n0,0,0,0\n0.5,1,nan,0\n1,0,0.1,0\n"),
        "text": write(tmp_path / "text.csv", "time,force,acc1,acc2\n0,0,0,0\n0.5,1,x,0\n1,0,0.1,0\n"),
        "empty": write(tmp_path / "empty.csv", ""),
        "header": write(tmp_path / "header.csv", "time,force,acc1,acc2\n"),
        "time": write(tmp_path / "time.csv", "time,force,acc1,acc2\n0,0,0,0\n0.5,1,0,0\n0.7,0,0.1,0\n"),
    }
    for name, path in bad.items():
        expected = cli_message(cli, "identify", path)
        assert py_message(frameid.read_records, [path]) == expected, name
    # Records of different sampling intervals (different lengths are one
    # campaign; different rates are refused).
    other = write(
        tmp_path / "other_rate.csv",
        "time,force,acc1,acc2\n0,0,0,0\n0.03125,1,0,0\n0.0625,0,0.1,0\n",
    )
    expected = cli_message(cli, "identify", hits[0], other)
    assert py_message(frameid.read_records, [hits[0], other]) == expected


def test_channel_errors_match_the_cli(cli, hits):
    cases = [
        (["--input", "nope"], dict(input="nope")),
        (["--outputs", "acc1,acc9"], dict(outputs=["acc1", "acc9"])),
        (["--outputs", "force,acc1"], dict(outputs="force,acc1")),
        (["--input", "#9"], dict(input="#9")),
        (["--input", "id:"], dict(input="id:")),
    ]
    for flags, kwargs in cases:
        expected = cli_message(cli, "identify", *hits, *flags)
        got = py_message(frameid.read_records, hits, **kwargs)
        # Messages that name the flag name the keyword instead.
        assert got.replace("input:", "--input:").replace("outputs:", "--outputs:") == expected or got == expected, (
            flags,
            got,
            expected,
        )


def test_identification_errors_match_the_cli(cli, hits):
    camp = frameid.read_records(hits)
    cases = [
        (["--order", "2"], dict(order=2)),
        (["--order", "80"], dict(order=80)),
        (["--outputs", "acc1"], "one output"),
        (["--order", "6", "--observer-order", "1"], dict(order=6, observer_order=1)),
    ]
    for flags, kwargs in cases:
        expected = cli_message(cli, "identify", *hits, *flags)
        if kwargs == "one output":
            got = py_message(frameid.identify, frameid.read_records(hits, outputs=["acc1"]))
        else:
            got = py_message(frameid.identify, camp, **kwargs)
        assert got == expected, flags


def test_dead_force_and_strict_match_the_cli(cli, hits, tmp_path):
    # A record whose force is all zeros: no hit, and a dead channel.
    lines = open(hits[1], encoding="utf-8").read().splitlines()
    zero = [lines[0]] + [",".join([c.split(",")[0], "0"] + c.split(",")[2:]) for c in lines[1:]]
    silent = write(tmp_path / "hit02.csv", "\n".join(zero) + "\n")
    files = [hits[0], silent, *hits[2:]]
    expected = cli_message(cli, "identify", *files, "--strict")
    assert py_message(frameid.identify, frameid.read_records(files), strict=True) == expected
    # Without --strict the hit is dropped with the same warnings.
    code, out, err = cli("identify", *files, "--json")
    assert code == 0, err
    doc = json.loads(out)
    res = frameid.identify(frameid.read_records(files))
    assert res.dropped_hits == doc["dropped_hits"] == [silent]
    assert res.warnings == doc["warnings"]


def test_scenario_errors_match_the_cli(cli, tmp_path):
    bad = write(tmp_path / "bad.toml", '[structure]\nkind = "matrices"\nmass = [[1]]\n')
    expected = cli_message(cli, "simulate", bad, "--out", tmp_path / "o")
    assert py_message(frameid.simulate, bad) == expected
    expected = cli_message(cli, "sweep", bad, "--out", tmp_path / "o")
    assert py_message(frameid.sweep, bad) == expected
    missing = str(tmp_path / "none.toml")
    assert py_message(frameid.simulate, missing) == cli_message(cli, "simulate", missing, "--out", tmp_path / "o")


def test_sweep_directory_errors_match_the_cli(cli, tmp_path):
    a = frameid.sweep(CASE1, noise=[0.01], trials=2, seed=1, shard=(1, 2), threads=1).write(tmp_path / "a")
    b = frameid.sweep(CASE1, noise=[0.01], trials=2, seed=2, shard=(2, 2), threads=1).write(tmp_path / "b")
    expected = cli_message(cli, "merge", a.path, b.path, "--out", tmp_path / "m")
    assert py_message(frameid.merge, [a.path, b.path], out=tmp_path / "m") == expected
    assert py_message(frameid.merge, [a.path, b.path]) == expected
    expected = cli_message(cli, "merge", a.path, "--out", tmp_path / "m")
    assert "missing" in expected
    assert py_message(frameid.merge, [a.path], out=tmp_path / "m") == expected
    assert py_message(frameid.merge, [a]) == expected
    expected = cli_message(cli, "report", tmp_path / "nothing", "--out", tmp_path / "r.html")
    assert py_message(frameid.report, [tmp_path / "nothing"], tmp_path / "r.html") == expected


@pytest.mark.parametrize(
    "force_shape, acc_shape, match",
    [
        ((4, 2048), (4, 2, 2048), r"force: expected an array of shape \(hits, inputs, samples\)"),
        ((4, 1, 2048), (4, 2048), r"acc: expected an array of shape \(hits, outputs, samples\)"),
        ((4, 1, 2048), (3, 2, 2048), "does not match force"),
        ((4, 1, 2048), (4, 2, 2000), "does not match force"),
        ((0, 1, 5), (0, 2, 5), "is empty"),
        ((4, 1, 2048, 1), (4, 2, 2048), "got 4 dimension"),
    ],
)
def test_wrong_shapes(force_shape, acc_shape, match):
    with pytest.raises(frameid.Error, match=match):
        frameid.Campaign(np.zeros(force_shape), np.zeros(acc_shape), 1 / 64)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_samples(case1, bad):
    camp, _ = case1
    acc = camp.acc.copy()
    acc[3, 1, 100] = bad
    with pytest.raises(frameid.Error, match=r"acc\[3, 1, 100\] is not finite"):
        frameid.Campaign(camp.force, acc, camp.dt_s)
    force = camp.force.copy()
    force[0, 0, 7] = bad
    with pytest.raises(frameid.Error, match=r"force\[0, 0, 7\] is not finite"):
        frameid.Campaign(force, camp.acc, camp.dt_s)


def test_argument_errors(case1):
    camp, _ = case1
    bad_calls = [
        (lambda: frameid.Campaign(camp.force, camp.acc, 0), "dt_s: must be a positive"),
        (lambda: frameid.Campaign(camp.force, camp.acc, float("nan")), "dt_s: must be a positive"),
        (lambda: frameid.Campaign("text", camp.acc, 1 / 64), "force: not an array of numbers"),
        (lambda: frameid.Campaign(camp.force, camp.acc, 1 / 64, outputs=["a"]), "outputs: 1 name"),
        (lambda: frameid.Campaign(camp.force, camp.acc, 1 / 64, outputs=["a", "a"]), "'a' appears twice"),
        (lambda: frameid.read_records([]), "no record files given"),
        (lambda: frameid.read_records(42), "paths: expected a path"),
        (lambda: frameid.read_records(["x.csv"], fs=-1), "fs: must be a positive"),
        (lambda: frameid.identify("camp"), "campaign: expected a frameid.Campaign"),
        (lambda: frameid.identify(camp, collocated=(2, 0)), "collocated: output index 2 is out of range"),
        (lambda: frameid.identify(camp, collocated=(0, 1)), "collocated: input index 1 is out of range"),
        (lambda: frameid.identify(camp, collocated=("acc7", 0)), "collocated: no output named 'acc7'"),
        (lambda: frameid.identify(camp, collocated=(-1, 0)), "collocated: index -1 is negative"),
        (lambda: frameid.identify(camp, collocated=(0, 0, 0)), "collocated: expected 2 entries"),
        (lambda: frameid.identify(camp, collocated="acc1"), "collocated: expected .* 'OUT:IN'"),
        (lambda: frameid.identify(camp, collocated="acc1:hammer"), "collocated: no input named 'hammer'"),
        (lambda: frameid.identify(camp, intersample="linear"), "intersample: expected `zoh` or `bandlimited`"),
        (lambda: frameid.identify(camp, observer_order=0), "observer_order: must be at least 1"),
        (lambda: frameid.identify(camp, parametrization="diagonal", refine=True), "parametrization: expected"),
        (lambda: frameid.identify(camp, parametrization="shear-frame"), "pass refine=True"),
        (lambda: frameid.identify(camp, strict=True, drop_bad_hits=True), "choose one"),
        (lambda: frameid.simulate(CASE1, hits=0), "hits: must be at least 1"),
        (lambda: frameid.simulate(CASE1, noise=-0.1), "noise: must be a fraction"),
        (lambda: frameid.simulate(CASE1, acquisition="scope"), "acquisition: expected"),
        (lambda: frameid.simulate(CASE1, format="xls"), "format: expected"),
        (lambda: frameid.bound(CASE1, 0), "noise-free records bound nothing"),
        (lambda: frameid.sweep(CASE1, noise=[]), "noise: give at least one level"),
        (lambda: frameid.sweep(CASE1, noise=[0.01, 0.01]), "noise: level 0.01 appears twice"),
        (lambda: frameid.sweep(CASE1, noise=[float("nan")]), "noise: level 1 must be a fraction"),
        (lambda: frameid.sweep(CASE1, trials=0), "trials: must be at least 1"),
        (lambda: frameid.sweep(CASE1, threads=0), "threads: must be at least 1"),
        (lambda: frameid.sweep(CASE1, shard=(0, 4)), "shard: need 1 <= K <= N"),
        (lambda: frameid.sweep(CASE1, shard="2of4"), "shard: expected K/N"),
        (lambda: frameid.merge([]), "no directories given"),
        (lambda: frameid.merge([42]), "parts: expected"),
        (lambda: frameid.report([], "r.html"), "at least one sweep directory"),
        (lambda: frameid.identify_realization("absent.json"), "absent.json"),
    ]
    for call, match in bad_calls:
        with pytest.raises(frameid.Error, match=match):
            call()


def test_report_needs_written_sweeps(tmp_path):
    sw = frameid.sweep(CASE1, noise=[0.01], trials=1, threads=1)
    with pytest.raises(frameid.Error, match="write it first"):
        frameid.report([sw], tmp_path / "r.html")


def test_random_input_never_crashes():
    """Odd but finite data: tiny, constant, huge, single-channel, single-hit
    campaigns. Each either identifies or raises frameid.Error; none reaches
    a panic ("internal error")."""
    rng = np.random.default_rng(15)
    outcomes = set()
    for case in range(40):
        hits = int(rng.integers(1, 4))
        r = int(rng.integers(1, 3))
        m = int(rng.integers(1, 4))
        n = int(rng.choice([1, 2, 5, 17, 64, 300]))
        scale = float(rng.choice([0.0, 1e-300, 1.0, 1e300]))
        force = scale * rng.standard_normal((hits, r, n))
        acc = scale * rng.standard_normal((hits, m, n))
        if case % 5 == 0:
            force[:, :, n // 2] += 1.0  # a pulse
        camp = frameid.Campaign(force, acc, 1 / 64)
        try:
            frameid.identify(camp, refine=case % 3 == 0)
            outcomes.add("ok")
        except frameid.Error as e:
            assert "internal error" not in str(e), (case, str(e))
            outcomes.add("error")
    assert "error" in outcomes
