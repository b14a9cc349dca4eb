"""Shared fixtures: the repository's scenarios, simulated campaigns and the
``frameid`` command line (built by cargo; ``FRAMEID_BIN`` overrides it)."""

import json
import os
import subprocess
from pathlib import Path

import pytest

import frameid

REPO = Path(__file__).resolve().parents[2]
CASE1 = REPO / "scenarios" / "paper-case1.toml"
CASE1_REALIZATION = REPO / "scenarios" / "paper-case1-realization.json"


@pytest.fixture(scope="session")
def case1():
    """Paper case 1, 10 hits at 1 % noise, seed 1: (campaign, truth)."""
    return frameid.simulate(CASE1, hits=10, noise=0.01, seed=1)


@pytest.fixture(scope="session")
def case1_result(case1):
    """The default identification of ``case1`` (error bars included)."""
    camp, _ = case1
    return frameid.identify(camp, collocated=(0, 0))


@pytest.fixture(scope="session")
def case1_refined(case1):
    camp, _ = case1
    return frameid.identify(camp, refine=True)


@pytest.fixture(scope="session")
def frameid_bin():
    """Path of the ``frameid`` executable: ``FRAMEID_BIN``, or the one cargo
    builds in the repository (a no-op after ``cargo test``)."""
    given = os.environ.get("FRAMEID_BIN")
    if given:
        return given
    out = subprocess.run(
        ["cargo", "build", "--quiet", "--bin", "frameid", "--message-format=json"],
        cwd=REPO,
        capture_output=True,
        text=True,
    )
    if out.returncode != 0:
        pytest.fail(f"cargo build --bin frameid failed:\n{out.stderr}")
    for line in out.stdout.splitlines():
        msg = json.loads(line)
        if (
            msg.get("reason") == "compiler-artifact"
            and msg.get("executable")
            and msg["target"]["name"] == "frameid"
        ):
            return msg["executable"]
    pytest.fail("cargo did not report the frameid executable")


@pytest.fixture(scope="session")
def cli(frameid_bin):
    """Runs ``frameid ARGS`` in the repository; returns (code, stdout, stderr)."""

    def run(*args, cwd=REPO):
        out = subprocess.run(
            [frameid_bin, *map(str, args)], cwd=cwd, capture_output=True, text=True
        )
        return out.returncode, out.stdout, out.stderr

    return run
