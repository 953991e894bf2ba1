#!/usr/bin/env bash
# Copies rustdds 0.15.1 from the cargo registry into vendor/rustdds-0.15.1, applies
# patches/rustdds-0.15.1/*.patch in order, and prints the Cargo.toml entry that builds with it.
# Nothing runs this during a build: wiring the patched crate in is a decision for the repository.
set -euo pipefail
cd "$(dirname "$0")/.."
registry="${CARGO_HOME:-$HOME/.cargo}/registry/src"
find_src() { find "$registry" -mindepth 2 -maxdepth 2 -type d -name rustdds-0.15.1 2>/dev/null | head -n 1; }
src=$(find_src)
if [ -z "$src" ]; then
    cargo fetch --locked --target "$(rustc -vV | sed -n 's/^host: //p')" >/dev/null
    src=$(find_src)
fi
if [ -z "$src" ]; then
    echo "vendor-rustdds: rustdds-0.15.1 is not in $registry" >&2
    exit 2
fi
dest=vendor/rustdds-0.15.1
rm -rf "$dest"
mkdir -p vendor
cp -r "$src" "$dest"
# The published Cargo.toml builds the library only: its examples, tests and interop scripts are not needed.
rm -rf "$dest/examples" "$dest/tests" "$dest/interop" "$dest/.cargo-ok"
for p in patches/rustdds-0.15.1/*.patch; do
    patch --quiet --forward -d "$dest" -p1 < "$p"
    echo "applied $p" >&2
done
printf '\n[patch.crates-io]\nrustdds = { path = "%s" }\n' "$dest"
