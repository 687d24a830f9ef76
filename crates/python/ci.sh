#!/usr/bin/env bash
# The Python package's CI (called by .ci/run): builds the abi3 wheel with maturin, installs it into a
# FRESH virtual environment holding only NumPy and pytest (the install may fetch nothing: it proves
# NumPy is the only requirement), and runs tests/*.py against the command line's outputs.
# Needs python3 (≥ 3.9, with venv) and cargo; uses target/python-ci/ for its environments and wheel.
# Run from anywhere: it works from crates/python/, whose .cargo/config.toml shares the root's target/.
set -euo pipefail
cd "$(dirname "$0")"
ROOT="$(cd ../.. && pwd)"
WORK="$ROOT/target/python-ci"
PYTHON="${PYTHON:-python3}"
rm -rf "$WORK/test-env" "$WORK/wheels"
mkdir -p "$WORK"

echo "== python: the binary the tests compare with"
nice -n 19 cargo build --release --manifest-path "$ROOT/Cargo.toml" --bin splatseg

echo "== python: fmt and clippy (the crate is a workspace of its own, outside the root's checks)"
cargo fmt --check
nice -n 19 cargo clippy --release -- -D warnings

echo "== python: build the wheel (maturin)"
if [ ! -x "$WORK/build-env/bin/maturin" ]; then
  "$PYTHON" -m venv "$WORK/build-env"
  "$WORK/build-env/bin/pip" install -q --disable-pip-version-check "maturin>=1.5,<2"
fi
nice -n 19 "$WORK/build-env/bin/maturin" build --release --manifest-path Cargo.toml \
  --interpreter "$WORK/build-env/bin/python" --out "$WORK/wheels"

echo "== python: a fresh environment with only NumPy and pytest, then the wheel without an index"
"$PYTHON" -m venv "$WORK/test-env"
"$WORK/test-env/bin/pip" install -q --disable-pip-version-check numpy pytest
"$WORK/test-env/bin/pip" install -q --disable-pip-version-check --no-index "$WORK"/wheels/splatseg-*.whl

echo "== python: pytest"
# From the tests' folder, so `import splatseg` is the installed wheel, not the source tree.
cd tests
SPLATSEG_BIN="$ROOT/target/release/splatseg" nice -n 19 "$WORK/test-env/bin/python" -m pytest -q -p no:cacheprovider .
