#!/usr/bin/env bash
# Makes vendor/rustdds-0.15.1: RustDDS 0.15.1 as crates.io publishes it (checksum verified), with
# patches/rustdds-0.15.1/*.patch applied in order. Cargo.toml builds with it through
# [patch.crates-io].
#
#   bash patches/vendor-rustdds.sh            rewrite vendor/rustdds-0.15.1
#   bash patches/vendor-rustdds.sh --check    rebuild it in a temporary folder and fail when the
#                                             committed copy differs (tests/run.sh runs this)
set -euo pipefail
cd "$(dirname "$0")/.."
NAME=rustdds
VERSION=0.15.1
# The checksum Cargo.lock carried for crates.io's rustdds 0.15.1 before the patch replaced it.
SHA256=42683a88b9dc025d7d45771b88d20846443b4901ec4b045ca78b8dd316ab616f
DEST=vendor/$NAME-$VERSION
die() { printf 'vendor-rustdds: %s\n' "$*" >&2; exit 1; }

check=false
case "${1:-}" in
    --check) check=true ;;
    "") ;;
    *) die "usage: $0 [--check]" ;;
esac

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
crate="${CARGO_HOME:-$HOME/.cargo}/registry/cache/index.crates.io-1949cf8c6b5b557f/$NAME-$VERSION.crate"
if [ ! -f "$crate" ] || [ "$(sha256sum <"$crate" | cut -d' ' -f1)" != "$SHA256" ]; then
    crate="$work/$NAME-$VERSION.crate"
    curl -fsSL --retry 3 -o "$crate" "https://static.crates.io/crates/$NAME/$NAME-$VERSION.crate" \
        || die "cannot download $NAME $VERSION from static.crates.io"
fi
[ "$(sha256sum <"$crate" | cut -d' ' -f1)" = "$SHA256" ] || die "$crate does not have crates.io's checksum $SHA256"
tar -xzf "$crate" -C "$work"
made="$work/$NAME-$VERSION"
# The published Cargo.toml builds the library only: its examples, tests and interop scripts are not needed.
rm -rf "$made/examples" "$made/tests" "$made/interop" "$made/.cargo_vcs_info.json" "$made/.github" "$made/.gitignore"
for p in patches/$NAME-$VERSION/*.patch; do
    patch --quiet --forward --no-backup-if-mismatch -d "$made" -p1 <"$p" || die "$p does not apply"
done

if $check; then
    diff -r "$made" "$DEST" >"$work/diff" || {
        head -n 40 "$work/diff" >&2
        die "$DEST is not crates.io's $NAME $VERSION with patches/$NAME-$VERSION applied (bash $0 rewrites it)"
    }
    echo "vendor-rustdds: $DEST is crates.io's $NAME $VERSION with $(ls patches/$NAME-$VERSION/*.patch | wc -l) patches applied"
else
    rm -rf "$DEST"
    mkdir -p vendor
    cp -r "$made" "$DEST"
    echo "vendor-rustdds: wrote $DEST"
fi
