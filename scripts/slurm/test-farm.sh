#!/usr/bin/env bash
# Tests `lamina farm` on a real one-node Slurm (crates/lamina-cli/tests/slurm.rs): installs
# Debian's Slurm and munge when missing, then runs that test with LAMINA_SLURM_TEST=1. The
# cluster lives in a network namespace whose only interface is loopback
# (scripts/slurm/local-cluster.sh) and the test stops every daemon it started.
# Without root, apt or network namespaces it prints why and exits 0, except under CI (CI=true),
# where that is a failure.
set -euo pipefail
cd "$(dirname "$0")/../.."
cluster=scripts/slurm/local-cluster.sh

skip() {
    echo "test-farm: skipped: $*" >&2
    if [ "${CI:-}" = "true" ]; then
        echo "test-farm: CI must run the Slurm test" >&2
        exit 1
    fi
    exit 0
}

rc=0
bash "$cluster" install || rc=$?
if [ "$rc" -eq 77 ]; then skip "cannot install Slurm here (needs root and apt-get)"; fi
if [ "$rc" -ne 0 ]; then exit "$rc"; fi
if [ "$(id -u)" -ne 0 ]; then skip "the local cluster needs root"; fi
if ! unshare --net true 2>/dev/null; then skip "no network namespaces here (unshare --net failed)"; fi

# `--workspace` (the test is lamina-cli's): the same feature unification as `cargo test
# --release --workspace` before it, so nothing is compiled again (with `-p lamina-cli` cargo
# resolves features for that package alone and rebuilds some 50 crates).
LAMINA_SLURM_TEST=1 cargo test --release --workspace --test slurm -- --nocapture
