#!/usr/bin/env bash
# Builds the `lamina` Python package's wheel (maturin, from PyPI), installs it into a fresh
# virtual environment and runs its pytest suite (crates/lamina-py/tests). Called by .ci/run
# after `cargo test --release --workspace`, whose release artifacts the wheel's build reuses
# (only pyo3, numpy and lamina-py are compiled again) and whose target/release/lamina the
# tests compare against.
#
#   bash scripts/python/test.sh [pytest args...]
#
# Needs python3 (3.9 or later) with venv, and network access to PyPI for maturin, numpy and
# pytest (pip caches them). The environment is .venv-ci in the repository (ignored by git).
set -euo pipefail
cd "$(dirname "$0")/../.."
py="${PYTHON:-python3}"
venv=.venv-ci
if [ ! -x "$venv/bin/python" ]; then
    "$py" -m venv "$venv"
fi
"$venv/bin/pip" install -q --upgrade "maturin>=1.9.4,<2" "numpy>=1.21" "pytest>=7"
rm -rf target/wheels
"$venv/bin/maturin" build --release -m crates/lamina-py/Cargo.toml -o target/wheels
"$venv/bin/pip" install -q --force-reinstall --no-deps target/wheels/lamina-*.whl
export LAMINA_BIN="$PWD/target/release/lamina"
[ -x "$LAMINA_BIN" ] || cargo build --release -p lamina-cli
# From outside the source tree, so the installed package is what is tested.
cd /tmp
"$OLDPWD/$venv/bin/python" -m pytest -q "$OLDPWD/crates/lamina-py/tests" "$@"
