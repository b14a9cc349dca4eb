#!/usr/bin/env bash
# The Python package (python/): builds and installs it from source into a
# fresh virtual environment the way the README tells a user to
# (`pip install ./python`), then runs its pytest suite: the package's
# contract, pickling, errors against the command line's messages, agreement
# with `frameid identify --json`, `simulate` and `sweep` (the suite builds
# the binary with cargo, a no-op after `cargo test`), a sweep's shards on a
# Dask LocalCluster merged byte for byte, and the example script. Then the
# FRF and mode files of `records` against pyuff, an independent UFF reader
# and writer (records/tests/pyuff_check.py with the example
# records/examples/pyuff_check.rs).
#
#   bash .ci/python/run.sh
#
# Needs python3 (3.10 or later, with venv) and a Rust toolchain; numpy,
# pytest, dask, distributed, matplotlib, pyuff and maturin come from PyPI.
#   FRAMEID_PYTHON     the interpreter (default python3)
#   FRAMEID_CI_VENV    where the environment is made (default
#                      target/python-ci-venv, replaced on every run)
set -euo pipefail

repo=$(cd "$(dirname "$0")/../.." && pwd)
cd "$repo"
python=${FRAMEID_PYTHON:-python3}
venv=${FRAMEID_CI_VENV:-$repo/target/python-ci-venv}

"$python" -c 'import sys; assert sys.version_info >= (3, 10), sys.version' \
    || { echo "python: $python is missing or older than 3.10" >&2; exit 1; }
rm -rf "$venv"
"$python" -m venv "$venv"
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check --upgrade pip
# The package and what its tests use; matplotlib for the example script.
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check \
    ./python pytest numpy dask distributed matplotlib pyuff
# The Rust side of the bindings is held to the workspace's standards.
cargo fmt --manifest-path python/Cargo.toml -- --check
PYO3_PYTHON="$venv/bin/python" cargo clippy --manifest-path python/Cargo.toml --all-targets -- -D warnings
# From the repository root, so that `import frameid` is the installed
# package, not the source folder python/frameid (which lacks the extension).
"$venv/bin/python" -m pytest -p no:cacheprovider -q python/tests
# pyuff reads the UFF58 (ASCII, binary) and UFF55 files frameid writes, and
# writes UFF58 FRFs that frameid must read with the same values.
pyuff_dir="$repo/target/pyuff-check"
rm -rf "$pyuff_dir" && mkdir -p "$pyuff_dir"
cargo run --quiet -p records --example pyuff_check -- write "$pyuff_dir"
"$venv/bin/python" records/tests/pyuff_check.py "$pyuff_dir"
cargo run --quiet -p records --example pyuff_check -- read "$pyuff_dir"
